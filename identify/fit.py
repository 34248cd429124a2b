"""Fit a method to a recorded run: the common path of every front end.

:func:`fit_run` is the one fit: a :class:`~identify.runs.Run` and the
effects to fit with the density (none: equation (22) alone).  Without
effects it is :func:`fit_sequence`, the fit of input/output arrays, which
chooses the measured rows (all, or ``M`` at random with a seed), builds the
:class:`~identify.methods.Problem`, runs the method and measures the fit;
the command line, the study and session re-identification all go through
it, so they treat the methods alike."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .effects import Effect
from .effects.joint import Mapper, fit_with_effects
from .errors import IdentifyError
from .grid import Grid
from .memory import InitialState
from .methods import Problem, choose_rows, make_method
from .metrics import max_abs, normalised, rmse
from .model import PreisachModel
from .regressor_design import thermal_point_row
from .runs import Run
from .threads import blas_threads_for


@dataclass(frozen=True)
class FitReport:
    """A fitted model and how well it fits the measured rows.

    ``rmse`` and ``max_abs`` are in output units (um); ``nrmse`` is the RMSE
    divided by the range of the measured outputs.
    """

    method: str
    settings: dict[str, Any]
    model: PreisachModel
    rows: np.ndarray
    n_points: int
    rmse: float
    nrmse: float
    max_abs: float
    seconds: float
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_measured(self) -> int:
        return int(self.rows.size)


def measurement_rows(
    grid: Grid,
    inputs: np.ndarray,
    measurements: int | None,
    seed: int | None,
    thermal_term: bool,
    candidates: np.ndarray | None = None,
) -> np.ndarray:
    """Which rows to use: all ``candidates``, or ``measurements`` of them chosen at random.

    ``candidates`` (sorted row indices; default: every row) are the rows that
    were measured, e.g. in a session whose compressive plan applied points
    it did not measure.  With the thermal term on a square design with a
    thermal point (:func:`identify.regressor_design.thermal_point_row`: the damped
    oscillation plus the thermal point, in any order, the thermal point
    anywhere off the walls) the thermal point is always among the chosen
    rows (when it is a candidate): without it ``c_d`` is not identifiable.
    """
    n = len(inputs)
    pool = np.arange(n) if candidates is None else np.asarray(candidates, dtype=np.int64)
    if measurements is None:
        return pool
    thermal = thermal_point_row(grid, inputs) if thermal_term else None
    include = () if thermal is None else np.flatnonzero(pool == thermal)
    return pool[choose_rows(pool.size, measurements, seed, tuple(int(k) for k in include))]


def fit_sequence(
    grid: Grid,
    inputs: np.ndarray,
    outputs: np.ndarray,
    method: str = "ls",
    *,
    measurements: int | None = None,
    seed: int | None = 0,
    thermal_term: bool = True,
    rows: np.ndarray | None = None,
    initial: InitialState = "negative",
    history: np.ndarray | None = None,
    settings: dict[str, Any] | None = None,
    curves: np.ndarray | None = None,
    progress: Callable[[str], None] | None = None,
) -> FitReport:
    """Identify a model from inputs (V) and outputs (um) of equal length ``n``.

    ``rows`` (explicit measured rows) and ``measurements`` (how many to
    choose at random with ``seed``) are alternatives; with neither, every row
    with a finite output is used.  ``curves`` ``(n,)`` numbers the
    first-order reversal curve of every row (-1: none), for methods that
    identify from curves (``everett``).  ``progress``, when given, is called
    with the name of each stage as it starts (``"fitting"``, ``"scoring"``):
    the caller's hook for showing a long fit's progress (nothing here prints).
    """
    inputs = np.asarray(inputs, dtype=float)
    outputs = np.asarray(outputs, dtype=float)
    if inputs.shape != outputs.shape:
        raise IdentifyError(f"{inputs.size} inputs but {outputs.size} outputs: the lengths must match")
    if rows is not None and measurements is not None:
        raise IdentifyError("give either the measured rows or their number, not both")
    if rows is None and measurements is not None:
        rows = measurement_rows(grid, inputs, measurements, seed, thermal_term)
    estimator = make_method(method, **(settings or {}))
    problem = Problem.build(grid, inputs, outputs, rows, thermal_term, initial, history, curves=curves)
    if progress is not None:
        progress("fitting")
    estimator.fit(problem)
    if progress is not None:
        progress("scoring")
    fitted = problem.fitted(estimator.parameters_)[problem.rows]
    err = fitted - problem.measured
    return FitReport(
        method=method,
        settings=estimator.settings(),
        model=estimator.model_,
        rows=problem.rows,
        n_points=problem.n,
        rmse=rmse(err),
        nrmse=normalised(rmse(err), problem.measured),
        max_abs=max_abs(err),
        seconds=estimator.seconds_,
        info=estimator.info_,
    )


def fit_run(
    grid: Grid,
    run: Run,
    method: str = "ls",
    effects: list[Effect] | tuple[Effect, ...] = (),
    *,
    rows: np.ndarray | None = None,
    thermal_term: bool = True,
    settings: dict[str, Any] | None = None,
    curves: np.ndarray | None = None,
    progress: Callable[[str], None] | None = None,
    mapper: Mapper | None = None,
) -> FitReport:
    """Identify a model with ``effects`` (unfitted :class:`identify.effects.Effect` instances; none: equation
    (22) alone) from one recorded :class:`~identify.runs.Run`: its measured points (or only ``rows``, sorted
    indices ``(m,)`` of measured points), every applied point setting the memory.  The one fit every front
    end calls.

    Without effects this is :func:`fit_sequence` on those rows (``curves`` and ``progress`` as there; the
    run's other measured outputs stay visible to the methods that use the order of all outputs,
    ``cs_order``); with effects the density is fitted jointly with their terms (:mod:`identify.effects.joint`) and
    ``info`` adds ``base_rmse`` (the same fit without the effects, um), ``effect_settings`` and the number
    of linear ``solves``; ``mapper`` runs the effects' grid search's independent jobs (see
    :func:`~identify.effects.joint.fit_with_effects`).
    """
    chosen = list(effects)
    for e in chosen:
        if not isinstance(e, Effect):
            raise TypeError(f"effects are Effect instances (identify.effects.parse_effects), not {e!r}")
    if not chosen:
        return fit_sequence(grid, run.inputs, run.outputs, method, rows=run.rows if rows is None else rows,
                            thermal_term=thermal_term, settings=settings, curves=curves, progress=progress)
    if rows is not None:
        run = run.keeping(rows)
    with blas_threads_for(grid.n_cells + 2):  # the joint fit's many solves and products, on one thread when small
        joint = fit_with_effects(grid, [run], method, chosen, thermal_term=thermal_term, settings=settings,
                                 mapper=mapper)
    info = {**joint.info, "base_rmse": joint.base_rmse, "effect_settings": joint.settings}
    if any(e.loop() is not None for e in joint.model.effects):
        info["simulated_rmse"] = simulated_rmse(joint.model, run)
    return FitReport(
        method=method,
        settings=dict(joint.method_settings),
        model=joint.model,
        rows=run.rows,
        n_points=run.n,
        rmse=joint.rmse,
        nrmse=joint.nrmse,
        max_abs=joint.max_abs,
        seconds=joint.seconds,
        info=info,
    )


def simulated_rmse(model: PreisachModel, run: Run) -> float:
    """The rms error (um) of ``model`` predicting ``run`` on its own, over its measured points: what a stored
    model does on any run.  A model whose hysterons feel the output (``interaction``) is *fitted* with the
    measured output fed back, so its fit error can be far smaller than this."""
    from .effects.compose import predict_run

    rows = run.rows
    return rmse(predict_run(model, run)[rows] - run.outputs[rows])
