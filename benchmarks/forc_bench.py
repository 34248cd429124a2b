"""Real measured hysteresis: fit on the even-numbered FORCs, predict the odd-numbered ones.

    python benchmarks/forc_bench.py [FILE] [--levels 20,30,40,60] [--methods ls,everett,smooth_nn]
                                    [--all-points-levels 40] [--repeats 3] [--drift-correct scale|offset] [--json]

FILE defaults to the shared MD00-2361.forc.  The file is imported as
``rig import --format micromag`` does (into a temporary session), then for
every L and method: the model is identified from the measured points of
the even-numbered curves (``rig identify --curves even``) and applied to
the whole input history, and its errors are taken on the odd-numbered
curves (``rig validate --curves odd``): held-out RMSE, RMSE / output range
of the odd curves (``nrmse``) and the largest error, in the session's
output unit; with the fit's own nRMSE on the even curves and its times.

Then the large-fit figure: building the problem (regressor) and fitting
every measured point of the file at ``--all-points-levels`` (default 40),
the median of ``--repeats`` runs, per method.

Times are wall-clock seconds in this process; ``fit_s`` is the method's
own ``seconds_`` (the solver), ``build_fit_s`` the problem's construction
plus the fit.  Every problem on one grid is built on that grid's
:class:`~identify.regressor_design.Design`: the first fit on a grid builds the
regressor operator (about 0.3 s for every point at L = 40), the other
methods and the repeats re-fit on it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from identify import Grid, Problem, make_method
from identify.regressor_design import Design
from identify.metrics import max_abs, normalised, rmse
from identify.validation import validate_model
from sessions.forc_import import import_forc
from sessions.micromag import read_forc
from sessions.recording import load_recording

#: The shared measurement, ``../shared/data/forc/`` relative to the repository root (this file is in
#: ``benchmarks/`` of the repository).
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "forc" / "MD00-2361.forc"


def numbers(text: str, kind=int) -> list:
    return [kind(x) for x in text.split(",") if x.strip()]


def build_and_fit(design: Design, data, rows: np.ndarray, method: str):
    """(fitted method, build + fit seconds): the problem is built from the whole input history, on ``design``."""
    start = time.perf_counter()
    problem = Problem.on(design, data.outputs, rows, curves=data.curves)
    fitted = make_method(method).fit(problem)
    return fitted, time.perf_counter() - start


def held_out(data, model, rows: np.ndarray) -> dict:
    """Errors on ``rows`` with every point's memory from its whole history (as rig validate)."""
    outputs = np.full(data.outputs.shape, np.nan)
    outputs[rows] = data.outputs[rows]
    report = validate_model(model, data.inputs, outputs, check_range=False)
    return {"rmse": report.rmse, "nrmse": report.nrmse, "max_abs": report.max_abs, "n": report.n_measured}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", type=Path, default=SHARED)
    parser.add_argument("--levels", default="20,30,40,60", help="comma-separated L values")
    parser.add_argument("--methods", default="ls,everett,smooth_nn", help="comma-separated methods")
    parser.add_argument("--all-points-levels", type=int, default=40, help="L of the all-points fit (0: skip)")
    parser.add_argument("--all-points-methods", default="smooth_nn", help="methods of the all-points fit")
    parser.add_argument("--repeats", type=int, default=3, help="runs of the all-points fit (median)")
    parser.add_argument("--drift-correct", choices=("scale", "offset"), help="as rig import --drift-correct")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()
    methods = [m for m in args.methods.split(",") if m]

    with tempfile.TemporaryDirectory() as tmp:
        session = Path(tmp) / "forc.h5"
        start = time.perf_counter()
        import_forc(read_forc(args.file), session, drift=args.drift_correct)
        import_s = time.perf_counter() - start
        data = load_recording(session)
    measured = data.measured_rows
    c = data.curves[measured]
    even, odd = measured[c % 2 == 0], measured[c % 2 == 1]
    lo, hi = float(data.inputs[measured].min()), float(data.inputs[measured].max())
    unit = data.output_unit
    log = sys.stderr
    print(f"{args.file.name}: {int(data.curves.max()) + 1} curves, {measured.size} measured points "
          f"({even.size} on even curves, {odd.size} on odd), grid [{lo:g}, {hi:g}] {data.input_unit}; "
          f"imported in {import_s:.2f} s; drift correction: {args.drift_correct or 'none'}", file=log)

    rows_out = []
    for levels in numbers(args.levels):
        design = Design(Grid(levels, lo, hi), data.inputs, thermal_term=True)
        for method in methods:
            fitted, wall = build_and_fit(design, data, even, method)
            train = fitted.model_.predict(data.inputs)[even] - data.outputs[even]
            row = {"levels": levels, "method": method, "fit_s": fitted.seconds_, "build_fit_s": wall,
                   "train_nrmse": normalised(rmse(train), data.outputs[even]),
                   **held_out(data, fitted.model_, odd)}
            rows_out.append(row)
            print(f"L={levels:<3} {method:<10} held-out nrmse {row['nrmse']:.6g}  rmse {row['rmse']:.6g} {unit}  "
                  f"max {row['max_abs']:.4g}  train nrmse {row['train_nrmse']:.6g}  fit {row['fit_s']:.2f} s  "
                  f"build+fit {wall:.2f} s", file=log)

    all_points = []
    if args.all_points_levels:
        design = Design(Grid(args.all_points_levels, lo, hi), data.inputs, thermal_term=True)
        for method in [m for m in args.all_points_methods.split(",") if m]:
            walls, fits = [], []
            for _ in range(args.repeats):
                fitted, wall = build_and_fit(design, data, measured, method)
                walls.append(wall)
                fits.append(fitted.seconds_)
            all_points.append({"levels": args.all_points_levels, "method": method, "n": int(measured.size),
                               "build_fit_s": float(np.median(walls)), "fit_s": float(np.median(fits)),
                               "runs": walls})
            print(f"all {measured.size} points, L={args.all_points_levels}, {method}: build+fit median "
                  f"{np.median(walls):.2f} s (runs {', '.join(f'{w:.2f}' for w in walls)}), "
                  f"fit {np.median(fits):.2f} s", file=log)

    result = {"file": str(args.file), "n_measured": int(measured.size), "n_even": int(even.size),
              "n_odd": int(odd.size), "output_unit": unit, "drift_correction": args.drift_correct,
              "cores": os.cpu_count(), "held_out": rows_out, "all_points": all_points}
    if args.json:
        print(json.dumps(result))
        return
    print(f"| L | method | held-out nRMSE | held-out RMSE ({unit}) | max abs ({unit}) | fit nRMSE (even) "
          f"| fit s | build + fit s |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows_out:
        print(f"| {r['levels']} | `{r['method']}` | {r['nrmse']:.6g} | {r['rmse']:.6g} | {r['max_abs']:.3g} "
              f"| {r['train_nrmse']:.6g} | {r['fit_s']:.2f} | {r['build_fit_s']:.2f} |")
    for a in all_points:
        print(f"\nAll {a['n']} measured points, L = {a['levels']}, `{a['method']}`: build + fit "
              f"{a['build_fit_s']:.1f} s (median of {len(a['runs'])}), fit alone {a['fit_s']:.1f} s")


if __name__ == "__main__":
    main()
