"""The blind runner: draw the cases, calibrate them, record their runs, and diagnose each as a user would.

Usage (from the repository root)::

    python -m benchmarks.withheld.run --split dev --seeds 3            # a few seeds to tune on
    python -m benchmarks.withheld.run --split headline                 # the README's table (10 seeds)
    python -m benchmarks.withheld.run --split dev --effects creep,none --levels 1,3,8 --json out.json

Each case's identification and check sessions are recorded on the withheld
device (:mod:`benchmarks.withheld.generate`), then diagnosed by ``rig
diagnose --fit fit.h5 --check check.h5 --json`` -- in process through
click's runner (warm, the default) or as a fresh ``python -m rig`` process
(``--cold``) -- and only that JSON is read: ``verdict.status``,
``verdict.effect``, ``verdict.effects`` (``[effect]`` when absent),
``verdict.shrink``, ``verdict.share_closed`` and ``candidates``.

Printed: the confusion matrix, each family's rate against the issue's
target, the shrink and share closed per family, the pairs, and the wall
time per diagnosis.  ``--json OUT`` writes every case, every calibration
(the manifest: forms, strengths, achieved gaps) and the tables.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections import Counter, defaultdict
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from .generate import (
    PAIRS_PER_SEED,
    SPLITS,
    digest,
    draw_base,
    draws,
    forms_digest,
    make_cases,
    parse_selection,
)
from benchmarks.blind.scoring import ORACLE_Z, classify, four_columns, print_four_columns

from .jobs import calibration_job, case_job
from .generate import SCORED_LIBRARY as LIBRARY
from .physics import FAMILIES, OUTSIDE as _OUTSIDE

#: Held out of the diagnosis's library (gain_drift has joined it).
OUTSIDE = tuple(f for f in _OUTSIDE if f not in LIBRARY)

#: The issue's targets at 3 noise levels.
TARGETS = {"library": 0.90, "outside_ok": 0.80, "outside_wrong": 0.05, "none": 0.90, "pair": 0.70}
STATUSES = ("ambiguous", "unexplained", "no_gap")

# ====================================================================== scoring
def named(row: dict[str, Any]) -> list[str]:
    """The effects a verdict names: only an ``explained`` verdict names any."""
    v = row.get("verdict") or {}
    return list(v.get("effects") or []) if v.get("status") == "explained" else []


def outcome(row: dict[str, Any]) -> str:
    """The confusion matrix's column: the first named effect, else the status (or ``error``)."""
    if row.get("status") != "ok":
        return "error"
    n = named(row)
    if n:
        return n[0]
    return str((row.get("verdict") or {}).get("status"))


def score(row: dict[str, Any]) -> dict[str, bool]:
    """``ok``: what is asked for this kind of case (right, or honest-ambiguous for a library effect);
    ``wrong``: a name not among the true effects (or their nested forms); ``column``: the four-column
    outcome of :func:`benchmarks.blind.scoring.classify`, the same for every generator."""
    if row.get("status") != "ok":
        return {"ok": False, "wrong": False, "column": "error"}
    truth = list(row["case"]["effects"])
    honest = row.get("oracle_z") is not None and row["oracle_z"] < ORACLE_Z
    column = classify(row["kind"], truth, row["verdict"], honest)
    out = {"ok": column in ("right", "honest"), "wrong": column == "wrong", "column": column}
    if row["kind"] == "pair":
        n = set(named(row))
        out["one"] = column == "open" and len(set(truth) & n) == 1
    return out


def _num(x: Any) -> float | None:
    if isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x):
        return float(x)
    if isinstance(x, list) and x:  # a list of per-step values: the last is the overall one
        return _num(x[-1])
    return None


def _stats(xs: list[float]) -> dict[str, Any]:
    if not xs:
        return {"n": 0, "median": None, "min": None, "max": None}
    return {"n": len(xs), "median": float(np.median(xs)), "min": float(np.min(xs)), "max": float(np.max(xs))}


def tables(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Confusion matrix, rates against the targets, shrink and share closed, times."""
    by_label: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_label[r["label"]].append(r)
    order = [*LIBRARY, *OUTSIDE, "none"]
    labels = [lb for lb in order if lb in by_label] + sorted(lb for lb in by_label if lb not in order)
    columns: list[str] = [*LIBRARY]
    for r in rows:
        o = outcome(r)
        if o not in columns and o not in (*STATUSES, "error"):
            columns.append(o)
    columns += [*STATUSES, "error"]
    confusion = {lb: dict(Counter(outcome(r) for r in by_label[lb])) for lb in labels}
    multi = {lb: sum(len(named(r)) > 1 for r in by_label[lb]) for lb in labels}

    families = []
    for lb in labels:
        rs = by_label[lb]
        sc = [score(r) for r in rs]
        kind = rs[0]["kind"]
        done = [r for r in rs if r.get("status") == "ok"]
        fam = {
            "label": lb, "kind": kind, "n": len(rs), "diagnosed": len(done),
            "ok": sum(s["ok"] for s in sc), "wrong": sum(s["wrong"] for s in sc),
            "shrink": _stats([x for r in done if (x := _num(r["verdict"].get("shrink"))) is not None]),
            "share_closed": _stats([x for r in done if (x := _num(r["verdict"].get("share_closed"))) is not None]),
            "gap_sigma": _stats([r["gap_sigma"] for r in rs if r.get("gap_sigma") is not None]),
            "diagnose_s": _stats([r["diagnose_s"] for r in rs if r.get("diagnose_s") is not None]),
        }
        if kind == "pair":
            fam["one"] = sum(s.get("one", False) for s in sc)
        families.append(fam)

    def group(kind: str) -> dict[str, Any]:
        rs = [r for r in rows if r["kind"] == kind]
        sc = [score(r) for r in rs]
        return {"n": len(rs), "ok": sum(s["ok"] for s in sc), "wrong": sum(s["wrong"] for s in sc)}

    groups = {k: group(k) for k in ("library", "outside", "none", "pair")}
    times = [r["diagnose_s"] for r in rows if r.get("diagnose_s") is not None]
    return {"columns": columns, "confusion": confusion, "multi_named": multi, "families": families,
            "groups": groups, "diagnose_s": _stats(times),
            "record_s": _stats([r["record_s"] for r in rows if r.get("record_s") is not None])}


# ====================================================================== printing
_SHORT = {"thermal_lag": "lag", "creep": "creep", "baseline_drift": "base", "ambient_drift": "amb",
          "joule_power": "joule", "sensor_nonlinearity": "sens", "reversible": "rev", "interaction": "inter",
          "first_point": "first", "ambiguous": "AMBIG", "unexplained": "UNEXPL", "no_gap": "NO_GAP",
          "error": "ERR"}


def _pct(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "-"


def _range(s: dict[str, Any], fmt: str = ".2f") -> str:
    if not s["n"]:
        return "-"
    return f"{s['median']:{fmt}} [{s['min']:{fmt}}, {s['max']:{fmt}}]"


def print_tables(t: dict[str, Any], out: Any = sys.stdout) -> None:
    def p(*a: Any) -> None:
        print(*a, file=out)

    cols = t["columns"]
    singles = [f for f in t["families"] if f["kind"] != "pair"]
    pairs = [f for f in t["families"] if f["kind"] == "pair"]
    width = max([len(f["label"]) for f in singles] + [12])
    p("\nConfusion matrix (rows: true effect; columns: the first effect named, else the status; "
      "+k: k verdicts named several effects)")
    p(" " * width + "".join(f"{_SHORT.get(c, c)[:7]:>8}" for c in cols) + "   n")
    for f in singles:
        row = t["confusion"][f["label"]]
        extra = f"  +{t['multi_named'][f['label']]}" if t["multi_named"][f["label"]] else ""
        p(f"{f['label']:<{width}}" + "".join(f"{row.get(c, 0) or '.':>8}" for c in cols) + f"{f['n']:>4}{extra}")

    p("\nPer family at the case's gap (targets of issue 15 at 3 sigma)")
    p(f"{'effect':<{width}}  {'gap (sigma)':>18}  {'result':>16}  {'wrong name':>14}  target")
    for f in singles:
        if f["kind"] == "library":
            res, tgt = _pct(f["ok"], f["n"]), f"right name >= {TARGETS['library']:.0%}"
        elif f["kind"] == "outside":
            res, tgt = _pct(f["ok"], f["n"]), (f"unexplained/ambiguous >= {TARGETS['outside_ok']:.0%}, "
                                               f"wrong <= {TARGETS['outside_wrong']:.0%}")
        else:
            res, tgt = _pct(f["ok"], f["n"]), f"no_gap >= {TARGETS['none']:.0%}"
        p(f"{f['label']:<{width}}  {_range(f['gap_sigma']):>18}  {res:>16}  {_pct(f['wrong'], f['n']):>14}  {tgt}")
    g = t["groups"]
    p("")
    for kind, what, tgt in (("library", "right name", TARGETS["library"]),
                            ("outside", "unexplained/ambiguous", TARGETS["outside_ok"]),
                            ("none", "no_gap", TARGETS["none"]), ("pair", "both named", TARGETS["pair"])):
        if g[kind]["n"]:
            met = "met" if g[kind]["ok"] >= tgt * g[kind]["n"] else "NOT met"
            p(f"  {kind:<8} {what:<22} {_pct(g[kind]['ok'], g[kind]['n']):>16}   wrong name "
              f"{_pct(g[kind]['wrong'], g[kind]['n']):>14}   target {tgt:.0%}: {met}")

    if pairs:
        p("\nPairs (each effect at the level alone; gap: both together)")
        pw = max(len(f["label"]) for f in pairs)
        p(f"{'pair':<{pw}}  {'gap (sigma)':>18}  {'both':>6}  {'one':>4}  {'wrong':>5}  outcomes")
        for f in pairs:
            outs = ", ".join(f"{k} {v}" for k, v in sorted(t["confusion"][f["label"]].items()))
            p(f"{f['label']:<{pw}}  {_range(f['gap_sigma']):>18}  {f['ok']:>3}/{f['n']:<2}  {f['one']:>4}  "
              f"{f['wrong']:>5}  {outs}")

    p("\nShrink and share closed of the verdict, per family: median [min, max] over the verdicts that report them")
    p(f"{'effect':<{width}}  {'shrink':>24}  {'share closed':>24}  {'diagnose (s)':>22}")
    for f in singles:
        p(f"{f['label']:<{width}}  {_range(f['shrink']):>24}  {_range(f['share_closed']):>24}  "
          f"{_range(f['diagnose_s'], '.1f'):>22}")
    d = t["diagnose_s"]
    if d["n"]:
        p(f"\nWall time per diagnosis: median {d['median']:.1f} s [{d['min']:.1f}, {d['max']:.1f}] over {d['n']}; "
          f"recording both runs: median {t['record_s']['median']:.1f} s")


# ====================================================================== main
def _git() -> dict[str, Any]:
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=False).stdout.strip()
        dirty = bool(subprocess.run(["git", "status", "--porcelain"], capture_output=True, text=True,
                                    check=False).stdout.strip())
        return {"commit": head, "dirty": dirty}
    except OSError:
        return {}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.withheld.run",
                                 description="Blind withheld-forms benchmark of rig diagnose (issue 15).")
    ap.add_argument("--split", choices=sorted(SPLITS), default="dev",
                    help="dev: seeds to tune on; headline: the README's table, never tuned on [dev]")
    ap.add_argument("--seeds", type=int, help="N seeds of the split [3 for dev, 10 for headline]")
    ap.add_argument("--skip", type=int, default=0,
                    help="leave out the split's first K seeds (fresh seeds for a re-measurement) [0]")
    ap.add_argument("--levels", default="3", help="gap of each effect alone, in noise levels, comma-separated [3]")
    ap.add_argument("--effects", help="subset: family names, A+B, or the groups library, outside, none, pairs [all]")
    ap.add_argument("--pairs-per-seed", type=int, default=PAIRS_PER_SEED,
                    help=f"pairs of library effects per seed, walking through all 36 [{PAIRS_PER_SEED}]")
    ap.add_argument("--workers", type=int, default=2, help="worker processes [2]")
    ap.add_argument("--cold", action="store_true", help="diagnose in a fresh 'python -m rig' process per case")
    ap.add_argument("--keep", type=Path, help="keep every case's sessions and diagnosis JSON under this directory")
    ap.add_argument("--json", dest="json_out", type=Path, help="write the cases, the manifest and the tables")
    ap.add_argument("--manifest", type=Path, help="write the manifest only: every base device, drawn form, strength "
                                                   "and achieved gap")
    args = ap.parse_args(argv)
    try:
        levels = [float(x) for x in args.levels.split(",") if x.strip()]
        selection = parse_selection(args.effects)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    n_seeds = args.seeds if args.seeds is not None else (10 if args.split == "headline" else 3)
    try:
        cases = make_cases(args.split, n_seeds, levels, selection, args.pairs_per_seed, args.skip)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not cases:
        print("error: no case selected", file=sys.stderr)
        return 2
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)

    from rig.parallel import run_parallel, start_workers

    preload = ["benchmarks.withheld.jobs", "rig.cli"]
    start_workers(preload)
    t0 = time.perf_counter()
    needed = sorted({(c.seed, f, c.level) for c in cases for f in c.effects})
    print(f"withheld benchmark: split {args.split}, seeds {SPLITS[args.split][args.skip]}.. ({n_seeds}), "
          f"levels {levels}, {len(cases)} cases, {len(needed)} calibrations, {args.workers} workers", file=sys.stderr)
    cal_rows = run_parallel(calibration_job, needed, args.workers, desc="calibrate", unit="effect", preload=preload)
    cals = {(c["seed"], c["family"], c["level"]): c for c in cal_rows}
    t_cal = time.perf_counter() - t0
    jobs = [{"case": asdict(c), "cals": {f: cals[(c.seed, f, c.level)] for f in c.effects},
             "keep": str(args.keep) if args.keep else None, "cold": args.cold} for c in cases]
    rows = run_parallel(case_job, jobs, args.workers, desc="diagnose", unit="case", preload=preload)
    wall = time.perf_counter() - t0

    t = tables(rows)
    fdig = forms_digest(cal_rows)
    ddig = digest(draws(args.split, n_seeds, skip=args.skip))
    print_tables(t)
    four = four_columns([(r["kind"], r["label"], score(r)["column"]) for r in rows])
    t["four_columns"] = four
    print("\nFour columns (the same scoring for every generator: benchmarks/blind/scoring.py):")
    print_four_columns(four)
    failed_cal = [c for c in cal_rows if c.get("strength") is None]
    redrawn = sum(1 for c in cal_rows if (c.get("attempt") or 0) > 0)
    print(f"\nCalibration: {len(cal_rows)} effects in {t_cal:.0f} s ({redrawn} redrawn, {len(failed_cal)} unreachable); "
          f"total {wall:.0f} s for {len(rows)} cases ({wall / max(len(rows), 1):.1f} s per case on "
          f"{args.workers} workers)")
    errors = [r for r in rows if r.get("status") != "ok"]
    for r in errors[:10]:
        print(f"  {r['key']}: {r.get('status')}: {r.get('error')}")
    skipped = f", the first {args.skip} skipped" if args.skip else ""
    print(f"Split {args.split}: draws digest {ddig}, forms digest {fdig} (seeds {n_seeds}{skipped}, levels {levels})")
    manifest = {"split": args.split, "seeds": sorted({c.seed for c in cases}), "levels": levels,
                "draws_digest": ddig, "forms_digest": fdig,
                "bases": {str(s): draw_base(s) for s in sorted({c.seed for c in cases})},
                "families": {k: {"in_library": v.in_library, "unit": v.unit} for k, v in FAMILIES.items()},
                "cases": [{"key": c.key, "effects": list(c.effects)} for c in cases], "calibrations": cal_rows}
    if args.manifest:
        args.manifest.write_text(json.dumps(manifest, indent=1, default=float))
        print(f"wrote {args.manifest}")
    if args.json_out:
        args.json_out.write_text(json.dumps({
            "meta": {"split": args.split, "seeds": n_seeds, "skip": args.skip, "levels": levels,
                     "effects": sorted(selection),
                     "pairs_per_seed": args.pairs_per_seed, "workers": args.workers, "cold": args.cold,
                     "wall_s": wall, "calibration_s": t_cal, "git": _git()},
            "tables": t, "cases": rows, "manifest": manifest,
        }, indent=1, default=float))
        print(f"wrote {args.json_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
