"""Cold start: how long the ``rig`` command takes as a user runs it, in a fresh process each time.

    python benchmarks/cold_start.py [--repeats 11] [--methods ls,cs_nodct,...] [--json]

Cold figures run the real command (the ``rig`` console script of this
interpreter's environment) in a new process, end to end: interpreter
start, imports, reading the session, the fit, the output.  Every command
is run ``--repeats`` times in interleaved rounds (so a burst of load on a
shared machine hits every command alike) and the median is reported, with
its ratio to two references measured in the same rounds: ``python -c
pass`` (the interpreter alone) and ``python -c 'import numpy'``.

Each cold figure has the process's own CPU time (user + system, median)
beside the wall time: on a shared machine it stays close to the wall time
of a quiet one.  Warm figures run the same ``rig identify`` in this process after a first
run (imports done, per-grid caches filled), through the same entry point
(:func:`rig.cli.main`), and the fit alone (:func:`rig.reidentify.fit_job`).

The session is an L = 30 damped oscillation with the thermal point (467
points, all measured) recorded by ``rig acquire`` on the simulated device.
The machine's load average is printed before and after.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The methods ``rig identify`` is timed with (the fast path of each).
DEFAULT_METHODS = ("ls", "cs", "cs_order", "cs_order_nn", "cs_nodct", "smooth_nn")


def rig_executable() -> list[str]:
    """The ``rig`` console script installed beside this interpreter (else ``python -m rig``)."""
    exe = shutil.which("rig", path=os.path.dirname(sys.executable))
    return [exe] if exe else [sys.executable, "-m", "rig"]


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(argv: list[str], cwd: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system) of one fresh process running ``argv`` (s).

    The CPU time is what the process itself used: on a machine shared with
    other work it stays close to the wall time the same command takes on a
    quiet one.  A failure stops the benchmark.
    """
    wall, cpu, _ = run_captured(argv, cwd)
    return wall, cpu


def run_captured(argv: list[str], cwd: Path) -> tuple[float, float, str]:
    """:func:`run_once` with what the process printed (its standard output)."""
    cpu0 = _children_cpu()
    start = time.perf_counter()
    done = subprocess.run(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}): {done.stderr.strip()}")
    return elapsed, _children_cpu() - cpu0, done.stdout


def cold(commands: dict[str, list[str]], repeats: int, cwd: Path) -> dict[str, list[tuple[float, float]]]:
    """Every command ``repeats`` times, in interleaved rounds; (wall, CPU) seconds of each run."""
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
    for _ in range(repeats):
        for name, argv in commands.items():
            times[name].append(run_once(argv, cwd))
    return times


def warm(session: Path, method: str, repeats: int) -> tuple[float, float]:
    """Median seconds of ``rig identify`` run in this process after a first run, and of the fit alone."""
    from rig.cli import main
    from rig.reidentify import IdentifyOptions, fit_job, plan_job

    argv = ["rig", "identify", str(session), "--method", method, "--no-store"]

    def command() -> float:
        saved = sys.argv
        sys.argv = argv
        start = time.perf_counter()
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
                main()
        finally:
            sys.argv = saved
        return time.perf_counter() - start

    command()  # imports and per-grid caches
    whole = statistics.median(command() for _ in range(repeats))
    job = plan_job(session, IdentifyOptions(method=method, store=False))
    fit_job(job)
    fits = []
    for _ in range(repeats):
        start = time.perf_counter()
        fit_job(job)
        fits.append(time.perf_counter() - start)
    return whole, statistics.median(fits)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=11, help="fresh processes per command (median)")
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS), help="comma-separated rig identify methods")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = parser.parse_args()
    methods = [m for m in args.methods.split(",") if m]
    rig = rig_executable()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="rig-cold-") as tmp:
        cwd = Path(tmp)
        session = cwd / "s.h5"
        subprocess.run([*rig, "acquire", "--out", str(session), "--no-progress"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        commands = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
            "rig --version": [*rig, "--version"],
            "rig --help": [*rig, "--help"],
            **{f"rig identify s.h5 --method {m} --no-store": [*rig, "identify", "s.h5", "--method", m, "--no-store"]
               for m in methods},
        }
        times = cold(commands, args.repeats, cwd)
        warm_figures = {m: warm(session, m, args.repeats) for m in methods}
    load_after = os.getloadavg()
    medians = {name: statistics.median(w for w, _ in t) for name, t in times.items()}
    cpu = {name: statistics.median(c for _, c in t) for name, t in times.items()}
    python, numpy = medians["python -c pass"], medians["python -c 'import numpy'"]
    result = {
        "repeats": args.repeats,
        "cores": os.cpu_count(),
        "load_before": load_before,
        "load_after": load_after,
        "cold": {name: {"median_s": medians[name], "min_s": min(w for w, _ in t), "max_s": max(w for w, _ in t),
                        "cpu_s": cpu[name], "vs_python": medians[name] / python, "vs_numpy": medians[name] / numpy}
                 for name, t in times.items()},
        "warm": {m: {"command_s": w, "fit_s": f} for m, (w, f) in warm_figures.items()},
    }
    if args.json:
        print(json.dumps(result, indent=1))
        return
    print(f"load average before {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f}, "
          f"after {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}; {os.cpu_count()} cores; "
          f"median of {args.repeats} fresh processes per command, interleaved")
    print(f"{'cold (fresh process)':48s} {'median s':>9s} {'min s':>7s} {'max s':>7s} {'cpu s':>6s} "
          f"{'x python':>9s} {'x numpy':>8s}")
    for name, r in result["cold"].items():
        print(f"{name:48s} {r['median_s']:9.3f} {r['min_s']:7.3f} {r['max_s']:7.3f} {r['cpu_s']:6.3f} "
              f"{r['vs_python']:9.2f} {r['vs_numpy']:8.2f}")
    print(f"\n{'warm (in process, after a first run)':48s} {'command s':>9s} {'fit s':>7s}")
    for m, r in result["warm"].items():
        print(f"{'rig identify s.h5 --method ' + m + ' --no-store':48s} {r['command_s']:9.4f} {r['fit_s']:7.4f}")


if __name__ == "__main__":
    main()
