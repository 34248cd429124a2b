"""The oracle of a kept case: the true effect's own signal, scored as one more candidate.

For a case kept by ``python -m benchmarks.withheld.run --keep DIR --json
RUN.json``, the generator re-simulates the case's identification and check
runs without noise, with and without the withheld effect(s); their
difference is the effect's true signal (um) at every recorded point.  That
signal, as a candidate of a single coefficient (``oracle_total``, and for a
pair ``oracle_<family>`` for each effect's part), is scored beside the
library by the same diagnosis (:func:`identify.diagnosis.diagnose`) on the
case's own noisy sessions.

What it tells: when even the true signal does not beat a library candidate
on the held-out check data, the check run cannot tell the two apart and no
verdict rule can; when it does and the right candidate does not, the
candidate's family misses the form.  The oracle is a looking glass for
understanding failures -- it is never part of the benchmark's tables, and
the headline seeds must not be tuned on what it shows.

    python -m benchmarks.withheld.oracle --keep DIR --json RUN.json [CASE-KEY ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from identify.effects.base import OUTPUT, Columns, Context, Effect

from .generate import Bench, rms


def oracle_effect(name: str, signals: tuple[np.ndarray, ...]) -> Effect:
    """An unfitted candidate ``name`` of one coefficient whose column on run ``i`` is ``signals[i]``
    (um, ``(n_i,)``: the identification run, then the check run)."""

    class Oracle(Effect):
        summary = "the withheld effect's true signal (benchmark oracle)"
        stage = OUTPUT

        def applicable(self, runs: tuple[Any, ...]) -> str | None:
            return None

        def identifiable(self, runs: tuple[Any, ...], grid: Any) -> str | None:
            return None

        def settings_grid(self) -> list[dict[str, float]]:
            return [{}]

        def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
            if len(ctx.runs) != len(signals):
                raise ValueError(f"the oracle has {len(signals)} runs' signals, the diagnosis {len(ctx.runs)} runs")
            for run, s in zip(ctx.runs, signals):
                if s.shape != (run.n,):
                    raise ValueError(f"oracle signal of {s.shape[0]} points for run {run.name} of {run.n}")
            return Columns(tuple(np.asarray(s, dtype=float)[:, None] for s in signals), (name,), (False,), (-1,))

        def with_fit(self, ctx: Context, setting: dict[str, float], coef: np.ndarray, cols: Columns) -> Effect:
            return self

        def report(self, runs: tuple[Any, ...] = ()) -> dict[str, Any]:
            return {}

    Oracle.name = name
    Oracle.__qualname__ = Oracle.__name__ = f"Oracle_{name}"
    return Oracle()


def true_signals(bench: Bench, active: dict[str, tuple[dict[str, Any], float]]
                 ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The noise-free signal (um) of all of ``active`` together (``oracle_total``) and, when there are
    several, of each one's part (``oracle_<family>``: all minus all but it), on both runs."""
    both = bench.noise_free(active)
    none = bench.noise_free({})
    out = {"oracle_total": (both[0] - none[0], both[1] - none[1])}
    if len(active) > 1:
        for fam in active:
            other = bench.noise_free({f: a for f, a in active.items() if f != fam})
            out[f"oracle_{fam}"] = (both[0] - other[0], both[1] - other[1])
    return out


def run_case(keep: Path, row: dict[str, Any], calibrations: dict[tuple[int, str], dict[str, Any]],
             top: int = 6) -> dict[str, Any]:
    """Score the oracle of one kept case beside the library; a JSON-safe summary."""
    from identify.diagnosis import DiagnosisSettings, diagnose
    from identify.diagnosis.candidates import library
    from rig.diagnosis.loading import load_runs

    case = row["case"]
    seed, families = int(case["seed"]), list(case["effects"])
    bench = Bench(seed)
    active = {f: (calibrations[(seed, f)]["form"], float(calibrations[(seed, f)]["strength"])) for f in families}
    signals = true_signals(bench, active) if active else {}
    directory = keep / row["key"]
    runs = load_runs([directory / "fit.h5"], [directory / "check.h5"])
    oracles = [oracle_effect(n, s) for n, s in signals.items()]
    res = diagnose(runs.fit, runs.check, runs.grid, DiagnosisSettings(keep=False), candidates=library() + oracles)
    v = res.verdict
    return {"key": row["key"], "sigma_um": bench.sigma_um,
            "signal_rms_um": {n: rms(s[1]) for n, s in signals.items()},
            "status": v.status, "effects": list(v.effects), "reason": v.reason,
            "candidates": [{"effect": c.effect, "shrink": c.shrink, "z": c.z, "share_closed": c.share_closed}
                           for c in res.candidates[:top]]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.withheld.oracle", description=__doc__.split("\n")[0])
    ap.add_argument("--keep", type=Path, required=True, help="the directory the run kept its cases in")
    ap.add_argument("--json", type=Path, required=True, help="the run's --json output (its calibrations)")
    ap.add_argument("cases", nargs="*", help="case keys (e.g. dev-1-gain_drift-3sigma); default every kept case")
    args = ap.parse_args(argv)
    try:
        js = json.loads(args.json.read_text())
        rows = {r["key"]: r for r in js["cases"]}
        cals = {(int(c["seed"]), c["family"]): c for c in js["manifest"]["calibrations"]}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"error: {args.json} is not a withheld run's --json output ({exc})", file=sys.stderr)
        return 2
    keys = args.cases or [k for k in rows if (args.keep / k / "check.h5").exists()]
    missing = [k for k in keys if k not in rows or not (args.keep / k / "check.h5").exists()]
    if missing:
        print(f"error: no kept case {', '.join(missing)} in {args.keep} and {args.json}", file=sys.stderr)
        return 2
    for key in keys:
        out = run_case(args.keep, rows[key], cals)
        sizes = ", ".join(f"{n} {r / out['sigma_um']:.1f} sigma" for n, r in out["signal_rms_um"].items())
        print(f"{key}: {out['status']} {'+'.join(out['effects'])} -- {out['reason']} (signal rms on the check run: {sizes})")
        for c in out["candidates"]:
            share = "-" if c["share_closed"] is None else f"{c['share_closed']:.2f}"
            print(f"    {c['effect']:22s} shrink {c['shrink']:6.3f}  z {c['z']:6.1f}  share {share}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
