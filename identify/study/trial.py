"""One run of the study: a fresh truth, noise draw and choice of rows; every method on it.

Seeding: run ``r`` draws its densities (random profile), its noise shape and
its validation input from ``SeedSequence(seed, spawn_key=(0, r))`` and its
measured rows from ``SeedSequence(seed, spawn_key=(1, r, M))``.  A result
therefore depends on ``(seed, M, D, r)`` only, not on which process ran it
or in what order; and the points of a sweep share their truths and noise
shapes (noise ``D * u`` with ``u`` uniform on ``[-1/2, 1/2]``), which makes
the curves over ``M`` and ``D`` paired comparisons.

Metrics per method (:data:`METRICS`):

* ``model_rmse``, ``model_max``: RMSE and largest absolute difference
  between the identified model's output and the true (noise-free) output
  over the whole damped oscillation, divided by the true output's range
  (Tables 1 and 2, figure 4b);
* ``density_rmse``: RMSE of the cell weights (um; figures 4a, 5a);
* ``seconds``: the method's fit time;
* ``validation_rmse``: RMSE on a random validation input of
  ``validation_points`` values uniform on the range, against the true
  output, divided by its range (figure 6; the paper's validation output
  carries noise with D = 20, which we leave out so that the figure measures
  the model alone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..regressor_design import Design
from ..errors import IdentifyError
from ..excitation import damped_oscillation, random_input
from ..grid import Grid
from ..methods import Problem, choose_rows, make_method
from ..metrics import max_abs, output_range, rmse
from ..profiles import profile as make_profile
from ..regressor import regressor_matrix
from .setup import StudySetup
from .sparsity import Sparsity, dct_pair, sparsity

METRICS = ("model_rmse", "model_max", "density_rmse", "seconds", "validation_rmse")


@dataclass(frozen=True)
class TrialResult:
    """Metrics of every method in one run at one ``(M, D)``.

    ``metrics[name]`` is an array ordered as :data:`METRICS`, all NaN when
    the method failed on this run (``errors[name]`` says why).
    """

    measurements: int
    noise: float
    run: int
    metrics: dict[str, np.ndarray]
    errors: dict[str, str]
    sparsity: Sparsity


@dataclass(frozen=True, eq=False)
class StudyDesign:
    """The study's identification design at one L: the damped oscillation on ``[0, 1]`` without the
    thermal term, as the :class:`~identify.regressor_design.Design` whose operator and square solver every fit
    on it shares, and its dense ``S`` ``(N, N)`` (read-only), which the metrics use.

    Build it once and pass it to every :func:`run_trial` (a worker process of ``rig study`` builds
    one for all its trials); a trial without one builds its own.
    """

    design: Design
    regressor: np.ndarray

    @classmethod
    def of(cls, levels: int) -> "StudyDesign":
        grid = Grid(levels, 0.0, 1.0)
        design = Design(grid, damped_oscillation(grid, thermal_term=False), thermal_term=False)
        s = regressor_matrix(grid, design.inputs, thermal_term=False)
        s.flags.writeable = False
        return cls(design, s)

    @property
    def grid(self) -> Grid:
        return self.design.grid


def _study_design(setup: StudySetup, design: StudyDesign | None) -> StudyDesign:
    if design is None:
        return StudyDesign.of(setup.levels)
    if design.grid != setup.grid:
        raise IdentifyError(f"the study design is for L={design.grid.levels}, the setup for L={setup.levels}")
    return design


def _truth(setup: StudySetup, run: int):
    """Cell weights, noise shape ``u`` ``(N,)`` and validation input of run ``run``."""
    grid = setup.grid
    rng = np.random.default_rng(np.random.SeedSequence(setup.seed, spawn_key=(0, run)))
    weights = make_profile(setup.profile, grid, rng)
    shape = rng.uniform(-0.5, 0.5, setup.n_points)
    v_val = random_input(grid, setup.validation_points, seed=int(rng.integers(2**63)))
    return weights, shape, v_val


def _rows(setup: StudySetup, measurements: int, run: int) -> np.ndarray:
    seed = np.random.SeedSequence(setup.seed, spawn_key=(1, run, measurements))
    return choose_rows(setup.n_points, measurements, int(seed.generate_state(1, np.uint64)[0]))


def dct_example(setup: StudySetup, run: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(q, q_order)`` of the true outputs of run ``run`` (figure 3a, 3b)."""
    s = StudyDesign.of(setup.levels).regressor
    weights, _, _ = _truth(setup, run)
    return dct_pair(s @ np.append(weights, 0.0))


def run_trial(setup: StudySetup, measurements: int, noise: float, run: int,
              design: StudyDesign | None = None) -> TrialResult:
    """Simulate run ``run`` at ``(M, D)`` and identify it with every method of ``setup``, on ``design``
    (:class:`StudyDesign` at ``setup.levels``; built here when not given)."""
    study = _study_design(setup, design)
    grid, s = study.grid, study.regressor
    weights, shape, v_val = _truth(setup, run)
    w_true = np.append(weights, 0.0)  # mu0 = 0
    y_true = s @ w_true
    span = output_range(y_true)
    s_val = regressor_matrix(grid, v_val, thermal_term=False)
    y_val = s_val @ w_true
    span_val = output_range(y_val)
    problem = Problem.on(study.design, y_true + noise * shape, _rows(setup, measurements, run), regressor=s)
    metrics: dict[str, np.ndarray] = {}
    errors: dict[str, str] = {}
    for name in setup.methods:
        try:
            est = make_method(name).fit(problem)
        except IdentifyError as exc:
            metrics[name] = np.full(len(METRICS), np.nan)
            errors[name] = str(exc)
            continue
        w = est.parameters_
        err = s @ w - y_true
        metrics[name] = np.array([
            rmse(err) / span,
            max_abs(err) / span,
            rmse(w[: grid.n_cells] - weights),
            est.seconds_,
            rmse(s_val @ w - y_val) / span_val,
        ])
    return TrialResult(measurements, float(noise), run, metrics, errors, sparsity(y_true))


def run_trials(setup: StudySetup, keys: list[tuple[int, float, int]],
               design: StudyDesign | None = None) -> list[TrialResult]:
    """:func:`run_trial` for each ``(M, D, run)`` in ``keys`` (one task of a process pool), all on
    ``design`` (built once here when not given)."""
    study = _study_design(setup, design)
    return [run_trial(setup, m, d, r, study) for (m, d, r) in keys]
