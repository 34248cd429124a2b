"""One discriminating run for every case of a blind benchmark that did not come out right and clear.

For each row of a benchmark's ``--json`` whose case was kept (``--keep``)
and whose verdict was not a right ``explained`` (or a right ``no_gap``):

1. ``rig diagnose --fit fit.h5 --check check.h5 --discriminate plan.csv``
   designs the follow-up run (or says why none is needed or possible);
2. the same generator simulates the same device with the same mechanism(s)
   (form and strength from the row's calibration) over three schedules:
   the identification run, the check run and the plan, in that order on one
   clock (a drift goes on);
3. the three runs are written as that generator's logger writes them,
   imported, and diagnosed again with both check runs
   (``rig diagnose --fit fit.h5 --check check.h5 plan.h5``); the verdict is
   scored as before (:func:`~benchmarks.blind.scoring.classify`, without the
   oracle).

When the generator's realisation of the first two runs depends on how many
runs follow (its noise or timing stream), the after-diagnosis sees other
readings on them than the before-diagnosis did; :func:`prefix_stable` says
whether it does.  Then the two re-simulated runs are also diagnosed alone
(``before_same_readings``), and the table's "before" is that verdict: the
plan's own effect, not a new realisation's.

Usage::

    python -m benchmarks.blind.follow_up --json BENCH.json --keep DIR --out FOLLOW.json [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from .base import draw_device
from .run import READINGS, _rig, _worker_init, generator, import_run, schedules, simulate
from .scoring import classify


def needs_follow_up(row: dict[str, Any]) -> bool:
    """A case that did not come out right and clear: anything but ``right`` with ``explained`` or
    ``no_gap`` (an outside mechanism left ``unexplained`` is right but not clear: it is followed up too)."""
    v = row.get("verdict") or {}
    return not (row.get("outcome") == "right" and v.get("status") in ("explained", "no_gap"))


def prefix_stable(gen, device, sched, effects, seed: int, label: str) -> bool:
    """Whether the generator gives the first runs the same readings when another run follows."""
    two = simulate(gen, device, sched, effects, seed, label, True)
    three = simulate(gen, device, sched + [sched[-1]], effects, seed, label, True)
    return all(np.allclose(a["y_um"], b["y_um"]) for a, b in zip(two, three[:2]))


def _verdict(js: dict[str, Any]) -> dict[str, Any]:
    v = js["verdict"]
    return {"status": v["status"], "effects": v.get("effects") or [], "rivals": v.get("rivals") or [],
            "shrink": v.get("shrink")}


def achieved_separation(fit: Path, check: Path, plan: Path, between: list[str]) -> dict[str, float]:
    """What the simulated plan run achieved between the rivals (``identify.diagnosis.discriminate.achieved``):
    the first diagnosis is run again in this process (as ``rig diagnose`` does) for its fitted rivals."""
    from identify.diagnosis import DiagnosisSettings, diagnose
    from identify.diagnosis.discriminate import achieved, noise_of, rival_of
    from rig.diagnosis.discriminate import reference_check
    from rig.diagnosis.loading import load_runs

    loaded = load_runs([fit], [check])
    d = diagnose(loaded.fit, loaded.check, loaded.grid, DiagnosisSettings(),
                 monitors=[np.asarray(m.output, dtype=float) for m in loaded.unique_monitors()])
    reference = reference_check(list(loaded.check))
    rivals = [rival_of(d, n, reference) for n in between]
    run = load_runs([fit], [plan]).check[0]
    return achieved(rivals, d.base.model, run, noise_of(d))


def _failed(out: dict[str, Any], code: int, err: str) -> dict[str, Any]:
    """``out`` for a ``rig`` command that exited ``code``: its last line of stderr as the reason."""
    return {**out, "after": "error", "reason": err.strip().splitlines()[-1] if err.strip() else f"exit {code}"}


def follow_up(row: dict[str, Any], keep: Path) -> dict[str, Any]:
    """The before and after of one case (see the module doc)."""
    t0 = time.perf_counter()
    d = keep / f"{row['generator']}-{row['split']}-{row['seed']}-{row['label']}"
    out: dict[str, Any] = {k: row[k] for k in ("generator", "split", "seed", "label", "kind", "effects")}
    out.update(before=row.get("outcome"), before_verdict=row.get("verdict"))
    plan = d / "plan.csv"
    t1 = time.perf_counter()
    code, stdout, err = _rig("diagnose", "--fit", str(d / "fit.h5"), "--check", str(d / "check.h5"), "--json",
                             "--discriminate", str(plan), "--force")
    if code != 0:
        return _failed(out, code, err)
    disc = json.loads(stdout)["discriminate"]
    out.update(discriminate=disc, design_wall_s=time.perf_counter() - t1)
    if disc["plan"] is None:
        return {**out, "after": out["before"], "after_verdict": out["before_verdict"], "seconds": time.perf_counter() - t0}
    gen = generator(row["generator"])
    seed = row["seed"]
    device = draw_device(seed)
    sched = schedules(device, seed)
    from rig.acquisition.sequence import read_setpoint_file

    v, w = read_setpoint_file(plan)
    sched3 = sched + [{"v_V": v, "dwell_s": w, "readings": READINGS}]
    effects = [(c["family"], c["form"], c["strength"]) for c in row.get("calibrations", [])]
    out["prefix_stable"] = prefix_stable(gen, device, sched, effects, seed, row["label"])
    runs = simulate(gen, device, sched3, effects, seed, row["label"], True)
    paths = [import_run(device, r, d / f"{name}3.csv", d / f"{name}3.h5", "--force") for name, r in zip(("fit", "check", "plan"), runs)]
    out["achieved_separation"] = achieved_separation(d / "fit.h5", d / "check.h5", paths[2], disc["between"])
    if not out["prefix_stable"]:
        # the same readings without the plan: what the plan changed, apart from the new realisation
        code, stdout, err = _rig("diagnose", "--fit", str(paths[0]), "--check", str(paths[1]), "--json")
        if code != 0:
            return _failed(out, code, err)
        same = _verdict(json.loads(stdout))
        out.update(before_same_readings=classify(row["kind"], row["effects"], same), before_same_readings_verdict=same)
    code, stdout, err = _rig("diagnose", "--fit", str(paths[0]), "--check", str(paths[1]), str(paths[2]), "--json")
    if code != 0:
        return _failed(out, code, err)
    js = json.loads(stdout)
    out["after_verdict"] = _verdict(js)
    out["after"] = classify(row["kind"], row["effects"], out["after_verdict"])
    out["after_candidates"] = [{k: c.get(k) for k in ("effect", "shrink", "z")} for c in js["candidates"]]
    out["seconds"] = time.perf_counter() - t0
    return out


def _job(args: tuple[dict[str, Any], str]) -> dict[str, Any]:
    row, keep = args
    try:
        return follow_up(row, Path(keep))
    except Exception as exc:  # reported, not fatal to the table
        return {**{k: row.get(k) for k in ("seed", "label", "kind", "effects")}, "before": row.get("outcome"),
                "after": "error", "reason": f"{type(exc).__name__}: {exc}"}


def before_of(row: dict[str, Any], followed: dict[str, Any] | None) -> str:
    """The outcome a case's after-diagnosis is compared with: the benchmark's, or, where the follow-up
    re-simulated other readings of the first two runs, those readings' own (``before_same_readings``)."""
    if followed is not None and "before_same_readings" in followed:
        return followed["before_same_readings"]
    return row.get("outcome")


def table(rows: list[dict[str, Any]], all_rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per kind (and per family for one library mechanism): cases, right before, right after, wrong before
    and after (before: :func:`before_of`), how many were re-simulated with other readings, plans written, the
    median predicted separation (plan, check) and the rig time the plans take."""
    followed = {(r["seed"], r["label"]): r for r in rows}
    groups: dict[str, list[tuple[dict, dict | None]]] = {}
    for r in all_rows:
        key = r["kind"] if r["kind"] != "library" else f"library:{r['label']}"
        groups.setdefault(key, []).append((r, followed.get((r["seed"], r["label"]))))
        if r["kind"] == "library":
            groups.setdefault("library", []).append((r, followed.get((r["seed"], r["label"]))))
    out = {}
    for key, items in sorted(groups.items()):
        after = [f["after"] if f is not None else r.get("outcome") for r, f in items]
        before = [before_of(r, f) for r, f in items]
        plans = [f["discriminate"] for _, f in items if f is not None and (f.get("discriminate") or {}).get("plan")]
        out[key] = {
            "cases": len(items),
            "right_before": sum(b == "right" for b in before),
            "right_after": sum(a == "right" for a in after),
            "wrong_before": sum(b == "wrong" for b in before),
            "new_realisations": sum(f is not None and "before_same_readings" in f for _, f in items),
            "wrong_after": sum(a == "wrong" for a in after),
            "plans": len(plans),
            "separation_plan": float(np.median([p["predicted_separation"]["plan"] for p in plans])) if plans else None,
            "separation_check": float(np.median([p["predicted_separation"]["check"] or 0.0 for p in plans])) if plans else None,
            "rig_time_s": float(np.sum([p["rig_time_s"] for p in plans])) if plans else 0.0,
            "achieved": float(np.median([min(abs(x) for x in f["achieved_separation"].values()) for _, f in items
                                         if f is not None and f.get("achieved_separation")]))
            if any(f is not None and f.get("achieved_separation") for _, f in items) else None,
        }
    return out


def print_table(t: dict[str, Any]) -> None:
    print(f"{'kind':32s} {'cases':>5s} {'right':>11s} {'wrong':>9s} {'plans':>5s} {'S plan/check':>14s} "
          f"{'achieved':>8s} {'rig h':>6s} {'new readings':>12s}")
    for key, r in t.items():
        sep = "" if r["separation_plan"] is None else f"{r['separation_plan']:.1f}/{r['separation_check']:.1f}"
        print(f"{key:32s} {r['cases']:5d} {r['right_before']:4d} -> {r['right_after']:3d} "
              f"{r['wrong_before']:3d} -> {r['wrong_after']:2d} {r['plans']:5d} {sep:>14s} "
              f"{'' if r['achieved'] is None else format(r['achieved'], '.1f'):>8s} {r['rig_time_s'] / 3600:6.1f} "
              f"{r['new_realisations']:12d}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.blind.follow_up", description=__doc__.split("\n")[0])
    ap.add_argument("--json", type=Path, required=True, help="a blind benchmark's --json (its rows)")
    ap.add_argument("--keep", type=Path, required=True, help="the directory its cases were kept in (--keep)")
    ap.add_argument("--out", type=Path, help="write every follow-up and the table here")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    all_rows = [r for r in json.loads(args.json.read_text())["rows"] if r.get("outcome") not in ("error", "skipped")]
    todo = [r for r in all_rows if needs_follow_up(r)]
    print(f"{len(todo)} of {len(all_rows)} cases followed up", flush=True)
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers, initializer=_worker_init) as pool:
        for r in pool.map(_job, [(r, str(args.keep)) for r in todo]):
            rows.append(r)
            disc = r.get("discriminate") or {}
            sep = disc.get("predicted_separation") or {}
            print(f"  {r['seed']} {r['label']:36s} {r.get('before_same_readings', r['before']):6s} -> {r.get('after', ''):6s} "
                  f"plan {'yes' if disc.get('plan') else 'no ':3s} S {sep.get('plan') or 0:6.1f} "
                  f"(check {sep.get('check') or 0:6.1f}) achieved {r.get('achieved_separation')} "
                  f"{(r.get('after_verdict') or {}).get('status', r.get('reason', ''))} "
                  f"{','.join((r.get('after_verdict') or {}).get('effects') or [])}",
                  flush=True)
    t = table(rows, all_rows)
    print()
    print_table(t)
    if args.out:
        args.out.write_text(json.dumps({"json": str(args.json), "rows": rows, "table": t}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
