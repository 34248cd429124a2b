"""The model so far and the diagnosis's "where" bins, computed in a worker process that never blocks.

Two pure jobs, each a module-level function of a picklable job:

* :func:`refit` identifies equation (22) on every point measured so far
  with a fast method (``smooth_nn`` or ``ls``, :func:`identify.fit.fit_sequence`)
  and predicts every point applied so far, with the model's path through
  the loop.  On the damped oscillation the thermal term cannot be
  identified until the thermal point (the last one) is measured -- every
  earlier input sits on a wall, where ``v`` is an affine function of the
  other columns -- so the fit then runs without it and says so;
* :func:`where` runs the gap diagnosis (:func:`identify.diagnosis.diagnose`)
  of a model identified on one run against a check run, reading both
  session files (read-only) as they are now, and keeps what the page
  shows: the binned residuals, before and after the chosen effect, and the
  verdict.

Both run on a :class:`rig.watch.worker.Worker` process.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: Fewest measured points before a model is fitted.
MIN_POINTS = 3
#: At most this many points on the model's path through the loop (as ``rig report``).
PATH_POINTS = 20_000
#: Why a damped-oscillation fit runs without the thermal term until the thermal point.
NO_THERMAL = ("thermal term not yet identifiable from these points (on the damped oscillation every input "
              "before the thermal point sits on a wall); fitted without it")


@dataclass(frozen=True, eq=False)
class RefitJob:
    """Fit on the first ``inputs.size`` applied points; ``outputs`` ``(n,)`` NaN where not measured.

    ``levels``, ``v_min``, ``v_max`` (input unit) are the grid; ``thermal_term`` asks for the
    ``c_d v`` term (dropped, with a note, while it cannot be identified).
    """

    inputs: np.ndarray
    outputs: np.ndarray
    levels: int
    v_min: float
    v_max: float
    method: str = "smooth_nn"
    thermal_term: bool = True
    input_unit: str = "V"
    output_unit: str = "um"


@dataclass(frozen=True, eq=False)
class ModelSoFar:
    """A refit's result: arrays ``prediction`` ``(n,)`` at every applied point (NaN beyond the grid),
    ``rows`` ``(m,)`` the measured points fitted, ``path`` the model's ``(v, u)`` along the input's ramps;
    errors in output units; ``seconds`` the solver's time, ``wall_s`` the whole job's; ``error`` instead
    of a model."""

    n_samples: int
    method: str
    levels: int
    v_min: float
    v_max: float
    thermal_term: bool = False
    note: str = ""
    rows: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    prediction: np.ndarray = field(default_factory=lambda: np.empty(0))
    path: tuple[np.ndarray, np.ndarray] | None = None
    mu0: float = float("nan")
    c_d: float = float("nan")
    rmse: float = float("nan")
    nrmse: float = float("nan")
    max_abs: float = float("nan")
    seconds: float = float("nan")
    wall_s: float = float("nan")
    error: str | None = None

    @property
    def n_used(self) -> int:
        return int(self.rows.size)


def refit(job: RefitJob) -> ModelSoFar:
    """Identify on every measured point of ``job`` and predict every applied one (see the module doc)."""
    from identify import Grid, IdentifyError
    from identify.fit import fit_sequence
    from identify.validation import model_path

    t0 = time.perf_counter()
    n = int(job.inputs.size)
    common = dict(n_samples=n, method=job.method, levels=job.levels, v_min=job.v_min, v_max=job.v_max)
    try:
        grid = Grid(job.levels, job.v_min, job.v_max)
        note = ""
        try:
            report = fit_sequence(grid, job.inputs, job.outputs, job.method, thermal_term=job.thermal_term)
            thermal = job.thermal_term
        except IdentifyError as exc:
            if not job.thermal_term or "thermal term" not in str(exc):
                raise
            report = fit_sequence(grid, job.inputs, job.outputs, job.method, thermal_term=False)
            thermal, note = False, NO_THERMAL
        model = report.model
        steps = max(1, min(8, PATH_POINTS // max(1, n)))
        pv, pu = model_path(model, job.inputs, steps)
        return ModelSoFar(
            **common, thermal_term=thermal, note=note, rows=report.rows,
            prediction=within(grid, job.inputs, model.predict(job.inputs)), path=(pv, within(grid, pv, pu)),
            mu0=model.mu0, c_d=model.c_d, rmse=report.rmse,
            nrmse=report.nrmse, max_abs=report.max_abs, seconds=report.seconds,
            wall_s=time.perf_counter() - t0,
        )
    except (IdentifyError, ValueError, np.linalg.LinAlgError) as exc:
        return ModelSoFar(**common, error=str(exc), wall_s=time.perf_counter() - t0)


def within(grid, inputs: np.ndarray, outputs: np.ndarray) -> np.ndarray:
    """``outputs`` with NaN where ``inputs`` lie beyond the grid: there the model only answers with its
    saturated branch plus the thermal term's straight line, which is no prediction (a FORC protocol's
    saturation field, applied but not measured, is such an input)."""
    tol = 1e-9 * (grid.v_max - grid.v_min)
    return np.where((inputs >= grid.v_min - tol) & (inputs <= grid.v_max + tol), outputs, np.nan)


@dataclass(frozen=True)
class WhereJob:
    """Diagnose a model identified on ``fit`` against the check run ``check`` (session paths);
    ``levels`` the grid when the identification run records none."""

    fit: Path
    check: Path
    levels: int | None = None
    method: str = "ls"


@dataclass(frozen=True, eq=False)
class WhereSoFar:
    """The diagnosis as the page shows it: ``diagnosis`` stripped of what only the full report needs
    (it still draws with :func:`rig.plots.diagnosis.where_figure`), the check points judged, or ``error``."""

    n_check: int = 0
    diagnosis: Any = None
    warnings: tuple[str, ...] = ()
    seconds: float = float("nan")
    error: str | None = None


def where(job: WhereJob) -> WhereSoFar:
    """The gap diagnosis of ``job`` on both files as they are now (see the module doc)."""
    from identify import IdentifyError
    from identify.diagnosis import DiagnosisSettings, diagnose
    from sessions import DataFileError

    from ..diagnosis.loading import load_runs
    from ..errors import UserError

    t0 = time.perf_counter()
    try:
        loaded = load_runs([job.fit], [job.check], job.levels, allow_partial=True)
        d = diagnose(loaded.fit, loaded.check, loaded.grid, DiagnosisSettings(method=job.method),
                     monitors=[np.asarray(m.output, dtype=float) for m in loaded.unique_monitors()])
        slim = dataclasses.replace(d, base=None, evidence=None, points=None, residual_after={})
        return WhereSoFar(n_check=int(d.points.residual.size), diagnosis=slim,
                          warnings=tuple(loaded.warnings + list(d.warnings)), seconds=time.perf_counter() - t0)
    except (IdentifyError, UserError, DataFileError, ValueError, np.linalg.LinAlgError) as exc:
        return WhereSoFar(error=str(exc), seconds=time.perf_counter() - t0)
