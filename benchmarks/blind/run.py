"""The blind benchmark of ``rig diagnose`` on generators written by other authors (``gen_b`` to ``gen_s``).

For every case -- one mechanism of a generator, none, or two library
mechanisms at once -- on a device drawn from the seed (``base.draw_device``):

1. **schedules**: the identification run (the damped oscillation of L = 30
   with its thermal point, 20 s dwells) and a check run (``identify.diagnosis.check_design``:
   360 points, dwells 8-60 s, 15 % repeated set-points), K = 4 readings;
2. **calibration**: the mechanism's form is drawn by the generator from the
   seed, and its strength found (secant steps, ``benchmarks.withheld.generate.solve_strength``)
   so that the gap it opens on the check run is ``level`` noise levels: the
   rms of ``(model_eff - y_eff) - (model_0 - y_0)`` over the check points,
   noise-free, ``model`` identified by least squares on the identification
   run with and without it; forms that cannot reach it are drawn again;
3. **the runs**: simulated with noise by the generator, written as the
   generator's lab logs them (CSV traces ``t_s,v_V,deflection_um`` with
   ``dwell_s`` when its logger writes it), imported with ``rig import``
   (``--dwell-from-time`` when the trace has no dwells) and diagnosed with
   ``rig diagnose --fit fit.h5 --check check.h5 --json``, judged from the
   JSON alone;
4. **the oracle**, for an ``ambiguous`` verdict naming the true mechanism
   among two: the noise-free difference the mechanism makes (the true
   signal, one coefficient) is scored beside the library on the same
   sessions; if it cannot be told apart from the other rival either
   (paired ``z < 2``), the run cannot tell them apart, and the verdict is
   *honest-ambiguous*; and for an outside mechanism given a library name,
   the true signal is scored against each name (``oracle_z_named``): the
   scoring is unchanged, the figure says whether the runs held the evidence
   against the name, for a candidate of the mechanism's own form.

Scoring, four columns (:func:`classify`): **right** (a library mechanism
named alone; two named exactly; no gap on a clean device; an outside
mechanism left unexplained or ambiguous), **honest** (honest-ambiguous),
**open** (unexplained, cannot tell, no gap where there is one, or an
ambiguity the oracle says the run could resolve), **wrong** (any name that
is not the truth's).  See ``README.md`` for the commands and the tables of
record.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.withheld.generate import Unreachable, digest, solve_strength, stream

from .base import BaseDevice, draw_device
from .scoring import (ORACLE_Z, classify, four_columns, named_outside, oracle_separation, print_four_columns,
                      wants_oracle)

#: Generators this harness runs (sub-packages of ``benchmarks.blind``).
GENERATORS = ("gen_b", "gen_c", "gen_d", "gen_e", "gen_f", "gen_g", "gen_h", "gen_i", "gen_j", "gen_k", "gen_l", "gen_m", "gen_n", "gen_o", "gen_p", "gen_q", "gen_r", "gen_s")
#: Seeds of each split; disjoint.  The headline split is never used for tuning.
SPLITS = {"dev": range(1, 100_001), "headline": range(900_001, 1_000_001)}
#: Noise of one recorded point (um): as the project's own benchmark (psd noise 2 mV x 5 um/V / sqrt(4)).
SIGMA_UM = 0.005
READINGS = 4
CHECK_POINTS = 360
FIT_DWELL_S = 20.0
#: Pairs of library mechanisms each seed contributes.
PAIRS_PER_SEED = 4
#: Forms drawn at most before a mechanism is declared unreachable on a seed.
MAX_ATTEMPTS = 6
#: Mixed into every seed of this harness.
SALT = "blind-harness-1"


def generator(name: str):
    if name not in GENERATORS:
        raise SystemExit(f"unknown generator {name!r}; choose from {', '.join(GENERATORS)}")
    return importlib.import_module(f"benchmarks.blind.{name}")


# ====================================================================== schedules and simulation
def schedules(device: BaseDevice, seed: int) -> list[dict[str, Any]]:
    """The identification and check runs' set-points and dwells (s)."""
    from identify.diagnosis import check_design
    from identify.excitation import damped_oscillation

    v_fit = damped_oscillation(device.grid, True)
    rng = stream(SALT, seed, "check")
    check = check_design(device.v_min_V, device.v_max_V, CHECK_POINTS, seed=int(rng.integers(1, 2**31 - 1)))
    return [{"v_V": v_fit, "dwell_s": np.full(v_fit.size, FIT_DWELL_S), "readings": READINGS},
            {"v_V": check.inputs, "dwell_s": check.dwell_s, "readings": READINGS}]


def _sim_seed(seed: int, label: str) -> int:
    return int(stream(SALT, seed, label, "sim").integers(1, 2**31 - 1))


def simulate(gen, device, sched, effects, seed: int, label: str, noise: bool) -> list[dict[str, Any]]:
    """The generator's session: one dict per run (``t_s``, ``v_V``, ``y_um`` and maybe ``dwell_s``).  The
    realisation's seed depends on the seed only, so the noise-free runs of a calibration and the noisy
    runs share their drifts' paths."""
    return gen.simulate(device, sched, effects, _sim_seed(seed, "session"), SIGMA_UM if noise else None)


def gap_um(device: BaseDevice, sched, clean: list[dict], runs: list[dict]) -> float:
    """The gap a mechanism opens on the check run (see the module doc): noise-free ``runs`` against ``clean``."""
    from identify.fit import fit_sequence

    out = []
    for r in (clean, runs):
        model = fit_sequence(device.grid, np.asarray(r[0]["v_V"]), np.asarray(r[0]["y_um"]), "ls").model
        out.append(model.predict(np.asarray(r[1]["v_V"])) - np.asarray(r[1]["y_um"]))
    return float(np.sqrt(np.mean((out[1] - out[0]) ** 2)))


def calibrate(gen, seed: int, family: str, level: float, device, sched, clean) -> dict[str, Any]:
    """The family's form for ``seed`` and the strength that opens ``level`` noise levels."""
    target = level * SIGMA_UM
    rejected = []
    for attempt in range(MAX_ATTEMPTS):
        form = gen.draw_form(family, stream(SALT, seed, family, "form", attempt))

        def gap(s: float, form=form) -> float:
            return gap_um(device, sched, clean, simulate(gen, device, sched, [(family, form, s)], seed, family, False))

        try:
            s, g, n = solve_strength(gap, 1.0, target, 1e4)
        except Unreachable as exc:
            rejected.append({"attempt": attempt, "reason": str(exc)})
            continue
        return {"family": family, "form": form, "attempt": attempt, "strength": s, "gap_um": g, "evaluations": n,
                "rejected": rejected, "status": "ok"}
    return {"family": family, "form": None, "status": f"unreachable after {MAX_ATTEMPTS} forms", "rejected": rejected}


# ====================================================================== cases
def split_seeds(split: str, n: int, skip: int = 0) -> list[int]:
    return list(SPLITS[split][skip: skip + n])


def pairs_for(library: tuple[str, ...], index: int) -> list[tuple[str, str]]:
    """``PAIRS_PER_SEED`` pairs of library mechanisms for the seed at ``index``: walking through every pair
    in a fixed shuffled order."""
    allp = [(a, b) for i, a in enumerate(library) for b in library[i + 1:]]
    order = np.random.default_rng(20_261_127).permutation(len(allp))
    return [allp[order[(index * PAIRS_PER_SEED + k) % len(allp)]] for k in range(PAIRS_PER_SEED)]


def cases(gen_name: str, split: str, n_seeds: int, skip: int, selection: set[str] | None) -> list[dict[str, Any]]:
    gen = generator(gen_name)
    out = []
    for index, seed in enumerate(split_seeds(split, n_seeds, skip), start=skip):
        labels = [(f,) for f in gen.LIBRARY] + [(f,) for f in gen.OUTSIDE] + [()] + \
            [tuple(p) for p in pairs_for(tuple(gen.LIBRARY), index)]
        for effects in labels:
            kind = ("none" if not effects else "pair" if len(effects) == 2 else
                    "library" if effects[0] in gen.LIBRARY else "outside")
            label = "+".join(effects) or "none"
            if selection and not ({label, kind} | set(effects)) & selection:
                continue
            out.append({"generator": gen_name, "split": split, "seed": seed, "effects": list(effects), "kind": kind,
                        "label": label})
    return out


# ====================================================================== one case
def _write_trace(path: Path, run: dict[str, Any]) -> bool:
    """The run as its lab's logger writes it; whether it has a dwell column."""
    with_dwell = run.get("dwell_s") is not None
    header = "t_s,v_V,deflection_um" + (",dwell_s" if with_dwell else "")
    cols = [run["t_s"], run["v_V"], run["y_um"]] + ([run["dwell_s"]] if with_dwell else [])
    lines = [header] + [",".join(repr(float(c[i])) for c in cols) for i in range(len(run["v_V"]))]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return with_dwell


def _rig(*args: str) -> tuple[int, str, str]:
    from click.testing import CliRunner

    from rig.cli import cli

    res = CliRunner().invoke(cli, list(args), catch_exceptions=True)
    err = res.stderr if res.stderr else (repr(res.exception) if res.exception else "")
    return res.exit_code, res.stdout, err


def import_run(device: BaseDevice, run: dict[str, Any], csv: Path, h5: Path, *extra: str) -> Path:
    """Write ``run`` as its lab's logger does (``csv``) and bring it in with ``rig import`` (``h5``);
    ``extra``: more ``rig import`` options (``--force``)."""
    with_dwell = _write_trace(csv, run)
    args = ["import", str(csv), "--out", str(h5), "--levels", str(device.levels), "--v-min",
            repr(device.v_min_V), "--v-max", repr(device.v_max_V), *extra]
    code, _, err = _rig(*args, *([] if with_dwell else ["--dwell-from-time"]))
    if code != 0:
        raise RuntimeError(f"rig import {csv.stem}: {err.strip()}")
    return h5


def _sessions(device: BaseDevice, runs: list[dict], directory: Path) -> tuple[Path, Path]:
    fit, check = (import_run(device, run, directory / f"{name}.csv", directory / f"{name}.h5")
                  for name, run in zip(("fit", "check"), runs))
    return fit, check


def run_case(case: dict[str, Any], level: float, keep: Path | None) -> dict[str, Any]:
    """Calibrate, simulate, import, diagnose and score one case (a worker's job)."""
    t0 = time.perf_counter()
    gen = generator(case["generator"])
    seed = case["seed"]
    device = draw_device(seed)
    sched = schedules(device, seed)
    clean = simulate(gen, device, sched, [], seed, "none", False)
    row: dict[str, Any] = {**case, "level": level, "calibrations": []}
    effects = []
    for family in case["effects"]:
        cal = calibrate(gen, seed, family, level, device, sched, clean)
        row["calibrations"].append(cal)
        if cal["status"] != "ok":
            row.update(outcome="skipped", reason=f"{family}: {cal['status']}", seconds=time.perf_counter() - t0)
            return row
        effects.append((family, cal["form"], cal["strength"]))
    if len(effects) == 2:  # the pair's joint gap, each at its single strength
        row["pair_gap_um"] = gap_um(device, sched, clean, simulate(gen, device, sched, effects, seed, case["label"], False))
    noisy = simulate(gen, device, sched, effects, seed, case["label"], True)
    directory = Path(tempfile.mkdtemp(prefix="blind-")) if keep is None else keep / f"{case['generator']}-{case['split']}-{seed}-{case['label']}"
    directory.mkdir(parents=True, exist_ok=True)
    try:
        fit, check = _sessions(device, noisy, directory)
        # what a judgement (and a re-judgement of kept cases) needs: the case, the true signal for the oracle
        (directory / "case.json").write_text(json.dumps({**case, "level": level}, default=str))
        np.savez(directory / "signals.npz", *[np.asarray(n["y_um"]) - np.asarray(c["y_um"]) for n, c in
                 zip(simulate(gen, device, sched, effects, seed, case["label"], False), clean)])
        row.update(judge(case, fit, check))
    finally:
        if keep is None:
            for p in directory.iterdir():
                p.unlink()
            directory.rmdir()
    row["seconds"] = time.perf_counter() - t0
    return row


def judge(case: dict[str, Any], fit: Path, check: Path) -> dict[str, Any]:
    """``rig diagnose --json`` on a case's sessions (``fit.h5``, ``check.h5``), read and scored
    (:func:`classify`), the oracle asked when the verdict is ambiguous (the true signal from
    ``signals.npz`` beside them)."""
    t1 = time.perf_counter()
    code, out, err = _rig("diagnose", "--fit", str(fit), "--check", str(check), "--json")
    row: dict[str, Any] = {"diagnose_s": time.perf_counter() - t1}
    if code != 0:
        return {**row, "outcome": "error", "reason": err.strip().splitlines()[-1] if err.strip() else f"exit {code}"}
    js = json.loads(out)
    v = js["verdict"]
    row["verdict"] = {"status": v["status"], "effects": v.get("effects") or [], "rivals": v.get("rivals") or [],
                      "shrink": v.get("shrink"), "reason": v.get("reason")}
    row["candidates"] = [{k: c.get(k) for k in ("effect", "shrink", "z", "share_closed")} for c in js["candidates"]]
    honest = False
    rival = wants_oracle(case["kind"], case["effects"], row["verdict"])
    if rival is not None:
        row["oracle_z"] = oz = oracle_separation(fit, check, _true_signals(fit), rival)
        honest = oz < ORACLE_Z
    named = named_outside(case["kind"], row["verdict"])
    if named:  # did the runs hold the evidence against the name? (the true signal, scored against each name)
        signals = _true_signals(fit)
        row["oracle_z_named"] = {n: oracle_separation(fit, check, signals, n) for n in named}
    row["outcome"] = classify(case["kind"], case["effects"], row["verdict"], honest)
    return row


def _true_signals(fit: Path) -> list[np.ndarray]:
    """The noise-free difference the case's mechanisms make, one array a run (``signals.npz`` beside ``fit``)."""
    with np.load(fit.parent / "signals.npz") as z:
        return [z[k] for k in sorted(z.files, key=lambda k: int(k.split("_")[1]))]


def _rejudge(directory: str) -> dict[str, Any]:
    d = Path(directory)
    case = json.loads((d / "case.json").read_text())
    try:
        return {**case, **judge(case, d / "fit.h5", d / "check.h5")}
    except Exception as exc:
        return {**case, "outcome": "error", "reason": f"{type(exc).__name__}: {exc}"}


def _worker_init() -> None:
    """One BLAS thread per worker: the workers already share the cores.  The environment variables reach
    only libraries not yet loaded; a forked worker inherits a loaded OpenBLAS, which threadpoolctl limits
    (without it, two workers were seen running four busy threads on two cores)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)


def _job(args: tuple[dict[str, Any], float, str | None]) -> dict[str, Any]:
    case, level, keep = args
    try:
        return run_case(case, level, Path(keep) if keep else None)
    except Exception as exc:  # a case that breaks is reported, not fatal to the table
        return {**case, "level": level, "outcome": "error", "reason": f"{type(exc).__name__}: {exc}"}


# ====================================================================== tables
def tables(rows: list[dict[str, Any]]) -> dict[str, Any]:
    return four_columns([(r["kind"], r["label"], r["outcome"]) for r in rows])


def print_named_outside(rows: list[dict[str, Any]]) -> None:
    """One line: how many outside cases got a library name, and in how many the mechanism's own signal beat
    every name it was given (paired ``z >= ORACLE_Z``): the runs held the evidence, for the right form."""
    named = [r for r in rows if r.get("oracle_z_named")]
    if named:
        beaten = sum(min(r["oracle_z_named"].values()) >= ORACLE_Z for r in named)
        print(f"outside named: {len(named)}; the true signal beats every name given (z >= {ORACLE_Z:g}) in {beaten}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.blind.run", description=__doc__.split("\n")[0])
    ap.add_argument("--generator", choices=GENERATORS)
    ap.add_argument("--split", choices=sorted(SPLITS), default="dev")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--skip", type=int, default=0)
    ap.add_argument("--level", type=float, default=3.0, help="gap of each mechanism alone, in noise levels [3]")
    ap.add_argument("--effects", help="labels, kinds (library, outside, none, pair) or families, comma-separated")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", type=Path, help="keep every case's traces and sessions here")
    ap.add_argument("--json", type=Path, help="write every case and the tables here")
    ap.add_argument("--rejudge", type=Path, metavar="DIR",
                    help="diagnose again the cases kept under DIR (--keep) with today's code; no simulation")
    args = ap.parse_args(argv)
    if args.rejudge:
        dirs = sorted(str(p.parent) for p in args.rejudge.glob("*/case.json"))
        with ProcessPoolExecutor(max_workers=args.workers, initializer=_worker_init) as pool:
            rows = list(pool.map(_rejudge, dirs))
        for row in rows:
            v = row.get("verdict", {})
            print(f"  {row['seed']} {row['label']:40s} {row['outcome']:8s} {v.get('status', row.get('reason', ''))!s:12s} "
                  f"{','.join(v.get('effects') or v.get('rivals') or [])}")
        print_four_columns(tables(rows))
        print_named_outside(rows)
        if args.json:
            args.json.write_text(json.dumps({"rejudge": str(args.rejudge), "rows": rows}, indent=1, default=str))
        return 0
    if args.generator is None:
        ap.error("--generator is required (unless --rejudge)")
    selection = set(args.effects.split(",")) if args.effects else None
    todo = cases(args.generator, args.split, args.seeds, args.skip, selection)
    gen = generator(args.generator)
    draws = [{"seed": s, "forms": {f: gen.draw_form(f, stream(SALT, s, f, "form", 0)) for f in (*gen.LIBRARY, *gen.OUTSIDE)}}
             for s in split_seeds(args.split, args.seeds, args.skip)]
    print(f"{args.generator} {args.split} seeds {todo[0]['seed'] if todo else '-'}..: {len(todo)} cases; "
          f"draws digest {digest(draws)}", flush=True)
    t0 = time.perf_counter()
    jobs = [(c, args.level, str(args.keep) if args.keep else None) for c in todo]
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers, initializer=_worker_init) as pool:
        for row in pool.map(_job, jobs):
            rows.append(row)
            v = row.get("verdict", {})
            print(f"  {row['seed']} {row['label']:40s} {row['outcome']:8s} {v.get('status', row.get('reason', ''))!s:12s} "
                  f"{','.join(v.get('effects') or v.get('rivals') or [])}", flush=True)
    t = tables(rows)
    print("", flush=True)
    print_four_columns(t)
    print_named_outside(rows)
    forms = digest(sorted((r["seed"], c["family"], c.get("attempt"), c.get("form")) for r in rows
                          for c in r.get("calibrations", []) if c.get("form") is not None))
    print(f"\nforms digest {forms}; {time.perf_counter() - t0:.0f} s")
    if args.json:
        args.json.write_text(json.dumps({"args": vars(args) | {"keep": str(args.keep), "json": str(args.json)},
                                         "draws_digest": digest(draws), "forms_digest": forms, "rows": rows,
                                         "tables": t}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
