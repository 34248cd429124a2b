"""Recorded runs (sessions or CSV traces) as :class:`identify.diagnosis.Run`, with the checks a
diagnosis needs: units, grids, distinct files.

Runs made of curves (an imported FORC measurement) may be split by curve
(``--fit-curves even --check-curves odd``): the same session then serves
as identification and check run, each scoring only its own curves while
every applied point still sets the memory state.  Such runs are large
(tens of thousands of points, and the diagnosis's carry-over matrix is
check points x identification points), so every ``stride``-th measured
point of each selected curve is used (the reversal point always), and the
applied points between them are dropped where the input only moves on
(interior points of a monotone stretch: by the wiping-out property the
memory state of every kept point is unchanged, see :func:`thin_run`).

Problems that make a diagnosis meaningless (unreadable files, runs in
different units, the same file to fit and to check on the same curves, no
grid, a partial session without ``--partial``: the rule of
:mod:`rig.session_input`) are one-line errors;
problems it can live with (a partial session allowed, a check run recorded
on another grid, identification runs on different grids) become warnings
in the report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from identify import Grid
from identify.acquisition_plan import reversal_points
from identify.diagnosis import Run
from sessions.records import CalibrationRecord
from sessions.recording import Recording

from ..curve_selection import selected_rows
from ..errors import UserError
from ..session_input import open_run, partial_state, run_of, same_file


#: Measured points per run made of curves that the default stride aims at (the carry-over matrix
#: is check points x identification points, about 70 MB at this size).
CURVE_RUN_POINTS = 3000


@dataclass
class Loaded:
    """The runs, the grid they are judged on, and what the user should know."""

    fit: list[Run]
    check: list[Run]
    grid: Grid
    warnings: list[str] = field(default_factory=list)
    #: Calibration points (drift monitor) of the runs that have them, by run name.
    monitors: dict[str, CalibrationRecord] = field(default_factory=dict)

    def unique_monitors(self) -> list[CalibrationRecord]:
        """The drift monitors, each once (a session split by curves is both runs)."""
        seen: list[CalibrationRecord] = []
        for m in self.monitors.values():
            if not any(np.array_equal(m.t_s, s.t_s) and np.array_equal(m.output, s.output) for s in seen):
                seen.append(m)
        return seen


def thin_rows(curves: np.ndarray, rows: np.ndarray, stride: int) -> np.ndarray:
    """Every ``stride``-th of the measured ``rows`` ``(m,)`` along each curve (``curves`` ``(n,)``
    numbers the curve of every point), starting at each curve's first: ``(m',)``, sorted."""
    if stride <= 1:
        return rows
    c = curves[rows]
    start = np.flatnonzero(np.concatenate([[True], c[1:] != c[:-1]]))
    position = np.arange(rows.size) - np.repeat(start, np.diff(np.concatenate([start, [rows.size]])))
    return rows[position % stride == 0]


def thin_run(run: Run) -> Run:
    """``run`` without the unmeasured points that lie inside a monotone stretch of its input.

    Kept: every measured point, every reversal point (where the input turns
    back), the first and the last.  By the wiping-out property of the
    Preisach memory, a point inside a monotone stretch changes nothing the
    later points remember, so every kept point has the same memory state
    (and the same model output) as in the whole run.
    """
    keep = np.isfinite(run.outputs) | reversal_points(run.inputs)
    keep[0] = keep[-1] = True
    if keep.all():
        return run
    return Run(run.name, run.inputs[keep], run.outputs[keep], run.t_s[keep], run.dwell_s[keep], run.readings,
               run.initial_V, run.input_unit, run.output_unit, run.by_curves)


def default_stride(selected: int) -> int:
    """The stride that keeps about :data:`CURVE_RUN_POINTS` of ``selected`` measured points."""
    return max(1, -(-selected // CURVE_RUN_POINTS))


def _names(paths: list[Path]) -> list[str]:
    stems = [p.stem for p in paths]
    return [str(p) if stems.count(p.stem) > 1 else p.stem for p in paths]


def _disjoint(fit_curves: str, check_curves: str) -> bool:
    return {fit_curves, check_curves} == {"even", "odd"}


def load_runs(fit_paths: list[Path], check_paths: list[Path], levels: int | None = None,
              v_min: float | None = None, v_max: float | None = None, *, allow_partial: bool = False,
              fit_curves: str = "all", check_curves: str = "all", stride: int | None = None,
              extra_checks: list[Path] = ()) -> Loaded:
    """Read every file and decide the grid (the first identification session's, unless given).

    ``fit_curves``/``check_curves`` (``all``, ``even``, ``odd``) select the
    curves scored in the identification and check runs; ``stride`` thins
    runs made of curves (default: :func:`default_stride`).  ``extra_checks``
    are further check runs scored on all their measured points whatever
    ``check_curves`` says (a discriminating run acquired after the others:
    ``rig diagnose --discriminate-on``); they come after ``check_paths``.
    """
    check_paths = list(check_paths) + list(extra_checks)
    if stride is not None and stride < 1:
        raise UserError(f"--stride {stride}: must be at least 1")
    for f in fit_paths:
        for c in check_paths:
            if same_file(f, c) and not _disjoint(fit_curves, check_curves):
                raise UserError(f"{c}: is also an identification run; the diagnosis judges only on "
                                "held-out runs, never on the data that was fitted (split a run made of "
                                "curves with --fit-curves even --check-curves odd)")
    selection = ([fit_curves] * len(fit_paths) + [check_curves] * (len(check_paths) - len(extra_checks))
                 + ["all"] * len(extra_checks))
    names = _names(list(fit_paths) + list(check_paths))
    names = [n if c == "all" else f"{n}:{c}" for n, c in zip(names, selection)]
    warnings: list[str] = []
    recordings = []
    for path in list(fit_paths) + list(check_paths):
        data = open_run(path, allow_partial=allow_partial)
        first = recordings[0] if recordings else data
        if (data.input_unit, data.output_unit) != (first.input_unit, first.output_unit):
            raise UserError(f"{path}: records {data.input_unit} in and {data.output_unit} out, but "
                            f"{first.path} records {first.input_unit} in and {first.output_unit} out; "
                            "a diagnosis compares runs in the same units")
        if data.session is not None and data.session.is_partial:
            warnings.append(f"{path}: partial session ({partial_state(data.session)}); using the points it holds")
        recordings.append(data)
    fit_data = recordings[: len(fit_paths)]
    grids = [d.grid for d in fit_data if d.grid is not None]
    # a run of curves spans its measured inputs (a FORC protocol's saturation field is applied unmeasured)
    span = fit_data[0].inputs[fit_data[0].measured_rows] if fit_data[0].curves is not None else fit_data[0].inputs
    unit = fit_data[0].input_unit
    if levels is not None:
        lo = v_min if v_min is not None else (grids[0].v_min if grids else float(np.min(span)))
        hi = v_max if v_max is not None else (grids[0].v_max if grids else float(np.max(span)))
        grid = Grid(levels, lo, hi)
    elif grids:
        g = grids[0]
        grid = Grid(g.levels, g.v_min if v_min is None else v_min, g.v_max if v_max is None else v_max)
    else:
        raise UserError(f"{fit_paths[0]}: records no grid; give --levels (and --v-min/--v-max)")
    for data in recordings:
        if data.grid is not None and data.grid != grid:
            role = "identification" if data in fit_data else "check"
            warnings.append(
                f"{data.path}: {role} run recorded on L={data.grid.levels} over [{data.grid.v_min:g}, "
                f"{data.grid.v_max:g}] {unit}, not the diagnosis grid L={grid.levels} over [{grid.v_min:g}, "
                f"{grid.v_max:g}] {unit}; it is used on the diagnosis grid"
            )
    runs = []
    for data, name, curves in zip(recordings, names, selection):
        rows = selected_rows(data, curves)
        if data.curves is not None:
            step = stride if stride is not None else default_stride(rows.size)
            kept = thin_rows(data.curves, rows, step)
            if kept.size < rows.size:
                warnings.append(f"{name}: one measured point in {step} of each curve is used ({kept.size} of "
                                f"{rows.size}; --stride)")
            runs.append(thin_run(run_of(data, name, kept)))
        else:
            runs.append(run_of(data, name, rows))
    monitors = {run.name: d.session.calibration for run, d in zip(runs, recordings)
                if d.session is not None and d.session.calibration is not None and len(d.session.calibration)}
    return Loaded(runs[: len(fit_paths)], runs[len(fit_paths):], grid, warnings, monitors)
