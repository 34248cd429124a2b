"""The base model (equation (22)) fitted on the identification runs, and its linearisation.

The base model is identified on the identification runs only -- all of
them together, each row with the memory state of its own run -- by any
registered method (``ls`` by default).  The diagnosis never lets it see a
check run.

**Linearisation.**  To fit a candidate *jointly* with the base model, the
diagnosis needs to know how the base fit responds when the identification
outputs change: an effect present during the identification run is
partly absorbed into the density, and the check run then sees the effect
minus what was absorbed.  Around the fitted solution the methods are
linear: NNLS (``ls``) is the least-squares solution on its free set ``F``
(the cells it left positive, plus ``mu0`` and ``c_d``), so
``w_F = pinv(X_F) y``.  :attr:`BaseFit.smoother` is that ``pinv(X_F)``;
for a check row ``x`` the *carry-over* ``x_F pinv(X_F)`` says how each
identification output moves its prediction.  It also propagates the
identification noise into the predictions: ``var = sigma^2 |x_F pinv(X_F)|^2``.
For ``smooth_nn`` the smoother is the penalised one on the free set,
``(X_F^T X_F + lam R_FF)^-1 X_F^T`` with the weight ``lam`` the fit chose.
For other methods the free set is every cell the fit left non-zero, which
is exact for a linear method on the square design and an approximation
otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import IdentifyError, MethodNotApplicable
from ..grid import Grid
from ..methods import Problem, make_method
from ..methods.triangle_penalty import dense_roughness_matrix
from ..model import PreisachModel
from ..regressor import regressor_matrix
from ..runs import Run

#: Singular values below this fraction of the largest are dropped from ``pinv(X_F)``.
PINV_RCOND = 1e-10
#: Cells whose weight is below this fraction of the largest count as zero (outside the free set).
ZERO_WEIGHT = 1e-12
#: A direction of the base fit that amplifies identification noise more than this into the check
#: predictions is "poorly determined" by the identification design (see :func:`uncertain_directions`).
AMPLIFICATION = 3.0
#: At most this many poorly determined directions are re-estimated.
MAX_UNCERTAIN = 3


@dataclass(frozen=True, eq=False)
class BaseFit:
    """The base model and what the diagnosis needs of it.

    ``rows`` maps each identification run's name to its measured row
    indices; the identification outputs are stacked in that order, ``(m,)``
    (``measured``, ``fitted``).  ``free`` ``(P,)`` marks the free set;
    ``smoother`` ``(|F|, m)`` is ``pinv(X_F)`` and ``design`` ``(m, |F|)`` is
    ``X_F``.  ``dof`` is ``m - rank X_F`` (residual degrees of freedom of the
    fit on its free set).
    """

    grid: Grid
    method: str
    thermal_term: bool
    model: PreisachModel
    fit_runs: tuple[Run, ...]
    measured: np.ndarray
    fitted: np.ndarray
    free: np.ndarray
    smoother: np.ndarray
    design: np.ndarray
    dof: int
    info: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def regressor(self, run: Run) -> np.ndarray:
        """``S`` of a run, ``(n, P)``, from negative saturation."""
        return regressor_matrix(self.grid, run.inputs, self.thermal_term)

    def predict(self, run: Run) -> np.ndarray:
        """Base-model output (um) at every point of ``run``, ``(n,)``."""
        return self.model.predict(run.inputs)

    def carry_over(self, regressor_rows: np.ndarray) -> np.ndarray:
        """``x_F pinv(X_F)`` for the given rows of ``S``: ``(k, m)``."""
        return np.asarray(regressor_rows)[:, self.free] @ self.smoother

    def carry_factor(self, regressor_rows: np.ndarray) -> np.ndarray:
        """``C`` ``(k, |F|)`` with ``carry_over(rows) = C Q^T``, ``Q`` ``(m, |F|)`` orthonormal (the QR
        factorisation of ``smoother^T``): the carry-over's singular values and left vectors at the cost of
        an SVD of ``C`` (:func:`uncertain_directions`)."""
        _, r = np.linalg.qr(self.smoother.T)
        return np.asarray(regressor_rows)[:, self.free] @ r.T

    def unabsorbed(self, columns: np.ndarray) -> np.ndarray:
        """``(I - X_F pinv(X_F)) C``: what the base fit cannot absorb of columns ``C`` ``(m, k)``
        given on the identification points (the residual-maker of the fit on its free set)."""
        c = np.asarray(columns, dtype=float)
        return c - self.design @ (self.smoother @ c)

    @property
    def residual(self) -> np.ndarray:
        """Measured minus fitted on the identification points (um), ``(m,)``."""
        return self.measured - self.fitted

    @property
    def m(self) -> int:
        return int(self.measured.size)


def uncertain_directions(carry: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The check-space patterns of the base fit's poorly determined directions.

    ``carry`` ``(m_check, m_fit)`` maps identification outputs to check
    predictions; its singular values are the noise amplification of each
    direction (``sigma`` of identification noise becomes ``s sigma`` of
    prediction error along the left singular vector).  Returns the left
    singular vectors ``(m_check, k)`` whose amplification exceeds
    :data:`AMPLIFICATION` (at most :data:`MAX_UNCERTAIN`) and all singular
    values ``(r,)``, largest first.  On the damped oscillation the first is
    the thermal term, which the design identifies through one point only
    (about 10x on the simulated bench).

    ``carry`` may be given in factored form: any ``(m_check, r)`` matrix
    ``C`` with ``carry = C Q^T`` for orthonormal ``Q`` has the same left
    singular vectors and values (:meth:`BaseFit.carry_factor`, far smaller).
    """
    if carry.size == 0:
        return np.zeros((carry.shape[0], 0)), np.zeros(0)
    u, s, _ = np.linalg.svd(carry, full_matrices=False)
    k = int(min(MAX_UNCERTAIN, np.sum(s > AMPLIFICATION)))
    return u[:, :k], s


def _pinv(a: np.ndarray) -> tuple[np.ndarray, int]:
    """Moore-Penrose inverse of ``a`` ``(m, k)`` -> ``(k, m)``, and the rank kept."""
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    keep = s > PINV_RCOND * (s[0] if s.size else 0.0)
    return (vt[keep].T / s[keep]) @ u[:, keep].T, int(keep.sum())


def _penalised(grid: Grid, x: np.ndarray, free: np.ndarray, weight: float) -> tuple[np.ndarray, int]:
    """``smooth_nn``'s smoother on its free set: ``(X_F^T X_F + lam R_FF)^-1 X_F^T`` and its trace
    (rounded), ``R`` the roughness penalty of the cells (``mu0`` and ``c_d`` unpenalised)."""
    cells = grid.n_cells
    penalty = np.zeros((free.size, free.size))
    penalty[:cells, :cells] = dense_roughness_matrix(grid)
    xf = x[:, free]
    smoother = np.linalg.solve(xf.T @ xf + weight * penalty[np.ix_(free, free)], xf.T)
    return smoother, int(round(float(np.trace(xf @ smoother))))


def _stack(grid: Grid, runs: tuple[Run, ...], thermal_term: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    inputs, outputs, blocks = [], [], []
    for run in runs:
        inputs.append(run.inputs)
        outputs.append(run.outputs)
        blocks.append(regressor_matrix(grid, run.inputs, thermal_term))
    return np.concatenate(inputs), np.concatenate(outputs), np.vstack(blocks)


def fit_model(
    grid: Grid,
    fit_runs: tuple[Run, ...] | list[Run],
    method: str = "ls",
    *,
    thermal_term: bool = True,
    settings: dict[str, Any] | None = None,
) -> tuple[Any, bool, tuple[str, ...], np.ndarray, np.ndarray]:
    """Identify equation (22) on the identification runs (stacked): the fitted estimator, whether it has
    the thermal term, notes, and the stacked outputs ``(n,)`` and regressor ``(n, P)``.

    Without an identifiable thermal term (every measured input on a wall)
    the model is fitted without one, and the notes say so.
    """
    runs = tuple(fit_runs)
    if not runs:
        raise IdentifyError("no identification run to fit the base model on")
    notes: list[str] = []
    inputs, outputs, reg = _stack(grid, runs, thermal_term)
    estimator = make_method(method, **(settings or {}))
    try:
        estimator.fit(Problem.build(grid, inputs, outputs, None, thermal_term, regressor=reg))
    except MethodNotApplicable as exc:
        if not thermal_term or "thermal term" not in str(exc):
            raise
        notes.append(f"fitted without the thermal term: {exc}")
        thermal_term = False
        inputs, outputs, reg = _stack(grid, runs, thermal_term)
        estimator = make_method(method, **(settings or {}))
        estimator.fit(Problem.build(grid, inputs, outputs, None, thermal_term, regressor=reg))
    return estimator, thermal_term, tuple(notes), outputs, reg


def fit_base(
    grid: Grid,
    fit_runs: tuple[Run, ...] | list[Run],
    method: str = "ls",
    *,
    thermal_term: bool = True,
    settings: dict[str, Any] | None = None,
) -> BaseFit:
    """Identify equation (22) on the identification runs (stacked, :func:`fit_model`) and linearise the fit."""
    runs = tuple(fit_runs)
    estimator, thermal_term, notes, outputs, reg = fit_model(grid, runs, method, thermal_term=thermal_term,
                                                             settings=settings)
    w = estimator.parameters_
    rows = np.flatnonzero(np.isfinite(outputs))
    x = reg[rows]
    cells = grid.n_cells
    free = np.ones(w.size, bool)
    scale = float(np.max(np.abs(w[:cells]), initial=0.0))
    free[:cells] = np.abs(w[:cells]) > ZERO_WEIGHT * scale if scale > 0 else False
    weight = estimator.info_.get("weight") if method == "smooth_nn" else None
    if weight:
        smoother, rank = _penalised(grid, x, free, float(weight))
    else:
        smoother, rank = _pinv(x[:, free])
    return BaseFit(
        grid=grid,
        method=method,
        thermal_term=thermal_term,
        model=estimator.model_,
        fit_runs=runs,
        measured=outputs[rows],
        fitted=x @ w,
        free=free,
        smoother=smoother,
        design=x[:, free],
        dof=int(rows.size - rank),
        info=dict(estimator.info_),
        notes=notes,
    )
