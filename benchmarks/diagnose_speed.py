"""How long the diagnosis takes, cold (a fresh ``rig`` process) and warm (in this process, imports done).

    python benchmarks/diagnose_speed.py [--repeats 3] [--skip-forc] [--cases NAME,...] [--json]

Cases (the figures the evidence-bound diagnosis and the discriminating run are held to):

* ``diagnose L=30 + 360``: ``rig diagnose`` on an L = 30 damped oscillation
  (467 points, 20 s dwells) and a 360-point check run recorded on the
  simulated bench with a creep on (``rig.diagnosis.simulate``); target 10 s;
* ``discriminate``: the same with ``--with thermal_lag,joule_power
  --discriminate`` (two rivals, the plan designed on top of the diagnosis);
  the design's own wall time is read from the JSON (``design_s``) of every
  cold and warm run (medians); target 20 s for the design;
* ``diagnose FORC``: the shared FORC file (``../shared/data/forc/``), even
  curves fitted and odd held out at L = 30 (about 30,000 points); target 30 s;
* ``identify FORC --with interaction``: ``rig identify --levels 30 --curves
  even --with interaction`` on it (41,907 measured of 84,179 points: the even
  curves hold half the file); target 20 s;
* ``identify FORC 15,000 --with interaction``: the same fitted on 15,000 of
  those points (``-M 15000``), the size the issue's target names; target 20 s.

``--cases`` times only the cases whose names contain one of the given
strings (``--cases interaction``: the last two cases); the discriminating
run's design is reported only when its case is timed.

Each cold case runs ``--repeats`` times in a fresh process (median wall and
CPU time, the load average printed); warm cases call the same entry point
in this process after a first run.  Cold figures include the interpreter's
start and the imports (about a second, see ``benchmarks/cold_start.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

# beside this file: run it as python benchmarks/diagnose_speed.py
from cold_start import rig_executable, run_captured, run_once

FORC = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "forc" / "MD00-2361.forc"


def _warm(argv: list[str], repeats: int) -> tuple[float, list[str]]:
    """The median wall time of ``repeats`` runs in this process after a first (s), and what each printed."""
    from rig.cli import main

    times, printed = [], []
    for _ in range(repeats + 1):
        out = io.StringIO()
        start = time.perf_counter()
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            main(argv)
        times.append(time.perf_counter() - start)
        printed.append(out.getvalue())
    return statistics.median(times[1:]), printed[1:]


def _design(printed: str) -> dict:
    """The ``discriminate`` object of a ``rig diagnose --json`` run's output."""
    return json.loads(printed)["discriminate"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-forc", action="store_true")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--cases", help="comma-separated parts of case names: time only the cases that contain one")
    ap.add_argument("--case", type=Path, metavar="DIR",
                    help="time the discriminating design on DIR/fit.h5 and DIR/check.h5 (a case kept by "
                         "python -m benchmarks.blind.run --keep) instead of the simulated bench's runs")
    args = ap.parse_args(argv)
    from rig.diagnosis.simulate import SimulatedBench, simulate

    work = Path(tempfile.mkdtemp(prefix="diagnose-speed-"))
    fit, check = simulate(SimulatedBench("creep", 0.1, seed=3, levels=30, check_points=360), work)
    cases = {
        "diagnose L=30 + 360": (["diagnose", "--fit", str(fit), "--check", str(check), "--json"], 10.0),
        "discriminate": (["diagnose", "--fit", str(args.case / "fit.h5" if args.case else fit), "--check",
                          str(args.case / "check.h5" if args.case else check),
                          *([] if args.case else ["--with", "thermal_lag,joule_power"]),
                          "--json", "--discriminate", str(work / "plan.csv"), "--force"], None),
    }
    if not args.skip_forc and FORC.exists():
        md = work / "md.h5"
        run_once(rig_executable() + ["import", str(FORC), "--format", "micromag", "--out", str(md)], work)
        cases["diagnose FORC L=30"] = (["diagnose", "--fit", str(md), "--check", str(md), "--fit-curves", "even",
                                        "--check-curves", "odd", "--levels", "30", "--json"], 30.0)
        cases["identify FORC --with interaction"] = (["identify", str(md), "--levels", "30", "--curves", "even",
                                                      "--with", "interaction", "--no-store", "--json"], 20.0)
        cases["identify FORC 15,000 --with interaction"] = (["identify", str(md), "--levels", "30", "--curves",
                                                             "even", "-M", "15000", "--with", "interaction",
                                                             "--no-store", "--json"], 20.0)
    if args.cases:
        wanted = [w.strip() for w in args.cases.split(",") if w.strip()]
        cases = {name: case for name, case in cases.items() if any(w in name for w in wanted)}
        if not cases:
            ap.error(f"--cases {args.cases!r} matches no case")
    print(f"load average before: {os.getloadavg()[0]:.2f}", flush=True)
    rows = {}
    for name, (cmd, target) in cases.items():
        cold = [run_captured(rig_executable() + cmd, work) for _ in range(args.repeats)]
        wall = statistics.median(c[0] for c in cold)
        cpu = statistics.median(c[1] for c in cold)
        warm, printed = _warm(cmd, max(1, args.repeats - 1))
        rows[name] = {"cold_wall_s": wall, "cold_cpu_s": cpu, "warm_s": warm, "target_s": target}
        if name == "discriminate":
            designs = {"cold": [_design(c[2]) for c in cold], "warm": [_design(p) for p in printed]}
        print(f"{name:36s} cold {wall:7.2f} s (cpu {cpu:6.2f} s)   warm "
              f"{'-' if warm is None else f'{warm:7.2f} s'}   target {'-' if target is None else f'{target:g} s'}",
              flush=True)
    if "discriminate" in cases:
        disc = designs["warm"][-1]
        times = {k: [d.get("design_s") for d in v] for k, v in designs.items()}
        med = {k: statistics.median(t) if None not in t else None for k, t in times.items()}
        rows["design"] = {"design_s": med["cold"], "warm_design_s": med["warm"], "runs_s": times,
                          "between": disc.get("between"), "points": disc.get("points"),
                          "predicted_separation": disc.get("predicted_separation"), "target_s": 20.0}
        print(f"{'design (median of the cold runs)':36s} {med['cold']} s, warm {med['warm']} s (runs: cold "
              f"{times['cold']}, warm {times['warm']}); {disc.get('between')}, {disc.get('points')} points, "
              f"separation {disc.get('predicted_separation')}   target 20 s"
              + ("" if disc.get("plan") else f"   (no plan: {disc.get('reason')})"))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
