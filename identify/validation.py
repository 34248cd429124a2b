"""Applying an identified model to a recorded run: prediction, residual and errors.

Used both on the run a model was fitted on (the residual over every measured
point, not only the rows the fit used) and on another run (validation, as
the paper's random-input test, figures 6 and 11).  The model can only speak
for inputs inside its grid: a run that goes beyond it is refused rather
than scored on saturated predictions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import numpy as np

from .effects.nuisance import held_out_prediction
from .errors import IdentifyError
from .grid import Grid
from .memory import InitialState
from .metrics import max_abs, normalised, output_range, rmse
from .model import PreisachModel
from .regressor import check_inputs
from .runs import Run


@dataclass(frozen=True, eq=False)
class ValidationReport:
    """A model's prediction of a run and its errors at the measured points.

    ``prediction`` ``(n,)`` covers every applied point (output units);
    ``rows`` ``(m,)`` are the measured points compared and ``residual``
    ``(m,)`` is prediction minus measurement there.  ``rmse`` and
    ``max_abs`` are in output units; ``nrmse`` is the RMSE divided by the
    range of the measured outputs (``output_range``).
    """

    prediction: np.ndarray
    rows: np.ndarray
    residual: np.ndarray
    rmse: float
    max_abs: float
    nrmse: float
    output_range: float
    #: Per-run effects of the model re-estimated on this run, held out (:mod:`identify.effects.nuisance`).
    nuisance: dict = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return int(self.prediction.size)

    @property
    def n_measured(self) -> int:
        return int(self.rows.size)


def check_covers(grid: Grid, inputs: np.ndarray, unit: str = "V") -> None:
    """Raise :class:`IdentifyError` unless every input lies on ``grid``'s range.

    Inputs within a billionth of the range of its ends count as on it.
    """
    v = check_inputs(inputs)
    tol = 1e-9 * (grid.v_max - grid.v_min)
    lo, hi = float(v.min()), float(v.max())
    if lo < grid.v_min - tol or hi > grid.v_max + tol:
        raise IdentifyError(
            f"the inputs span [{lo:g}, {hi:g}] {unit} but the model's grid covers only "
            f"[{grid.v_min:g}, {grid.v_max:g}] {unit}; it cannot predict outside it"
        )


def validate_model(
    model: PreisachModel,
    inputs: np.ndarray,
    outputs: np.ndarray,
    initial: InitialState = "negative",
    *,
    check_range: bool = True,
) -> ValidationReport:
    """Predict every input (V) and compare with ``outputs`` where they are finite.

    ``outputs`` ``(n,)`` holds NaN at points that were applied but not
    measured; those points still set the memory state.  ``check_range``
    refuses inputs beyond the model's grid (:func:`check_covers`); turn it
    off only for the run the model was fitted on, whose saturated inputs
    the fit itself saw.
    """
    v = check_inputs(inputs)
    y = np.asarray(outputs, dtype=float)
    if y.shape != v.shape:
        raise IdentifyError(f"{v.size} inputs but {y.size} outputs: the lengths must match")
    if check_range:
        check_covers(model.grid, v, model.input_unit)
    rows = np.flatnonzero(np.isfinite(y))
    if rows.size == 0:
        raise IdentifyError("no measured output to compare the model with")
    prediction = model.predict(v, initial)
    return _report(prediction, rows, y)


def _report(prediction: np.ndarray, rows: np.ndarray, y: np.ndarray, nuisance: dict | None = None) -> ValidationReport:
    residual = prediction[rows] - y[rows]
    measured = y[rows]
    return ValidationReport(
        prediction=prediction,
        rows=rows,
        residual=residual,
        rmse=rmse(residual),
        max_abs=max_abs(residual),
        nrmse=normalised(rmse(residual), measured),
        output_range=output_range(measured),
        nuisance=nuisance or {},
    )


def validate_run(model: PreisachModel, run: Run, *, check_range: bool = True) -> ValidationReport:
    """:func:`validate_model` for a model with effects, on a whole :class:`~identify.runs.Run`
    (its time stamps and dwells), from negative saturation.

    Per-run effects that do not know the run (drifts fitted on another run)
    are re-estimated on it held out (:mod:`identify.effects.nuisance`);
    :attr:`ValidationReport.nuisance` says which.  Raises
    :class:`identify.effects.EffectNotApplicable` when the run lacks what an
    effect needs.
    """
    rows = run.rows
    if rows.size == 0:
        raise IdentifyError("no measured output to compare the model with")
    if check_range:
        check_covers(model.grid, run.inputs, model.input_unit)
    prediction, nuisance = held_out_prediction(model, run)
    return _report(prediction, rows, run.outputs, nuisance)


def model_path(
    model: PreisachModel, inputs: np.ndarray, steps: int = 8, initial: InitialState = "negative"
) -> tuple[np.ndarray, np.ndarray]:
    """The model's output along straight ramps between consecutive inputs: ``(v, u)``, each ``(k,)``.

    The input moves monotonically from one applied point to the next (the
    heater's temperature follows its set-point without overshoot), so this
    is the path the model traces -- its hysteresis loops -- not straight
    lines between the points.  ``steps`` points per ramp, the applied
    inputs included (``k = 1 + (n - 1) * steps``).
    """
    v = check_inputs(inputs)
    if steps < 1:
        raise IdentifyError(f"steps must be >= 1, got {steps}")
    frac = np.arange(1, steps + 1) / steps
    ramps = v[:-1, None] + (v[1:] - v[:-1])[:, None] * frac[None, :]
    dense = np.concatenate([v[:1], ramps.reshape(-1)])
    return dense, model.predict(dense, initial)
