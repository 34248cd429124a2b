"""'Smooth Non-negative': non-negative least squares with a roughness penalty.

Our method, not the paper's.  On the measured rows only (no output order,
no square design: any input history)::

    min_w  ||A S w - y_b||_2^2 + lam ||D mu||_2^2     s.t.  mu >= 0

where ``mu`` are the cell weights, ``D`` takes the differences between cells
sharing an edge of the Preisach triangle
(:mod:`~identify.methods.triangle_penalty`), and the bias ``mu0`` and thermal
coefficient ``c_d`` are free and not penalised.  With fewer measurements than
cells the data leave many directions undetermined; NNLS alone fills them
with zeros at the boundary of the constraint set, while the penalty fills
them with what the neighbouring cells say.

The weight ``lam`` is chosen from the measured data alone by generalised
cross-validation (:mod:`~identify.methods.gcv`) unless given.

Like every method, ``solver="fast"`` (the default) or ``"dense"`` (the
reference).  The fast path has three algorithms for the same problem
(setting ``algorithm``; ``"auto"``, the default, takes ``"normal"`` up to
:data:`NORMAL_MAX_CELLS` cells, above that ``"outputs"`` on the square
damped-oscillation design and ``"iterative"`` on any other input):

* ``"normal"``: normal equations from operator products
  (:mod:`~identify.methods.normal_equations`), GCV by one eigendecomposition,
  then an exact active-set QP (:mod:`~identify.methods.nonneg_qp`).  Memory
  ``O(P^2)``.
* ``"outputs"`` (square design only): the problem written in the outputs
  ``b = S w`` with the sparse ``S^{-1}`` -- a diagonal data term and a
  sparse penalty -- weight by GCV up to 2048 measured rows, else held-out
  rows on sparse unconstrained fits, then Clarabel on the sparse QP
  (:mod:`~identify.methods.smooth_square`).  Memory ``O(n)`` plus one
  sparse factor.  Should it fail on degenerate measured rows, ``"auto"``
  falls back to ``"iterative"`` (``info_["fallback"]`` says why).
* ``"iterative"``: matrix-free L-BFGS-B on ``problem.operator`` with the
  weight chosen on held-out measured rows
  (:mod:`~identify.methods.smooth_large`).  Memory ``O(n + P)``; any input.

The dense reference (:func:`solve_dense`) takes the measured rows of the
dense ``S``, chooses the weight by the same GCV, and hands the penalised
problem above to cvxpy with Clarabel as written.

Like ``ls``, it refuses a thermal term that the measured rows cannot
identify (every measured input on a wall).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError, MethodNotApplicable
from .base import Method
from .gcv import gcv_weight
from .l1 import solve_clarabel
from .nonneg_qp import nonneg_qp
from .normal_equations import NormalEquations, normal_equations
from .problem import Problem
from .smooth_large import solve_iterative
from .triangle_penalty import dense_roughness_matrix, difference_matrix

#: Above this many cells (L = 62) the default algorithm is the iterative one.
NORMAL_MAX_CELLS = 2016
ALGORITHMS = ("auto", "normal", "iterative", "outputs")
#: Refinement steps of the final solution against residuals computed with
#: the operator (the normal equations square the condition number of S).
REFINEMENT_STEPS = 1


class SmoothNonNegative(Method):
    """Roughness-penalised NNLS; ``weight`` = ``lam`` (None: chosen by GCV).

    ``algorithm``: the fast path's ``"auto"`` (default), ``"normal"``,
    ``"outputs"`` or ``"iterative"``; ``solver``: ``"fast"`` or ``"dense"`` (the reference).
    """

    name = "smooth_nn"
    label = "Smooth Non-negative (ours)"
    refits_live = True

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        """Measured at L = 30/60 (normal equations), 100 (iterative), 100/200 (output space)."""
        p, n, m = parameters, points, measured
        if p - 2 <= NORMAL_MAX_CELLS:  # dense normal equations, GCV's eigendecomposition, the QP
            return 2e-9 * p ** 3 + 3e-7 * m * p + 0.3, 64.0 * p * p + 8.0 * min(m * p, 4e6)
        if square:  # output space: sparse factorisations along the weight path, then Clarabel
            return 5e-6 * n ** 1.5, 2e3 * n
        # L-BFGS-B on operator products along a hold-out path of weights
        return 1e-4 * (n + p) ** 1.5, 200.0 * p

    def __init__(self, weight: float | None = None, algorithm: str = "auto", solver: str = "fast") -> None:
        if weight is not None and not (np.isfinite(weight) and weight > 0):
            raise IdentifyError(f"smooth_nn weight must be a positive number, got {weight!r}")
        if algorithm not in ALGORITHMS:
            raise IdentifyError(f"smooth_nn algorithm must be one of {', '.join(ALGORITHMS)}, got {algorithm!r}")
        if solver in ALGORITHMS:
            raise IdentifyError(
                f"smooth_nn solver is fast or dense like every method's; {solver!r} is now its "
                f"algorithm setting (algorithm={solver!r})"
            )
        super().__init__(solver)
        self.weight = weight
        self.algorithm = algorithm

    def _solve(self, problem: Problem) -> tuple[np.ndarray, dict[str, Any]]:
        problem.require_thermal_identifiable(self.name)
        if self.dense:
            return solve_dense(problem, self.weight)
        from .smooth_square import solve_outputs  # here: Clarabel's import is paid by the fits that use it

        algorithm = self.algorithm
        if algorithm == "auto":
            if problem.n_cells <= NORMAL_MAX_CELLS:
                algorithm = "normal"
            elif _is_square(problem):
                try:
                    return solve_outputs(problem, self.weight)
                except IdentifyError as exc:  # degenerate measured rows: the iterative path copes
                    w, info = solve_iterative(problem, self.weight)
                    return w, {**info, "fallback": str(exc)}
            else:
                algorithm = "iterative"
        if algorithm == "outputs":
            problem.require_square()
            return solve_outputs(problem, self.weight)
        if algorithm == "iterative":
            return solve_iterative(problem, self.weight)
        return solve_normal(problem, self.weight)


def _is_square(problem: Problem) -> bool:
    try:
        problem.require_square()
    except MethodNotApplicable:
        return False
    return True


def _weight(ne, problem: Problem, weight: float | None) -> tuple[float, dict[str, Any]]:
    """The given weight, or GCV's choice on the normal equations ``ne``."""
    if weight is not None:
        return float(weight), {"selection": "given"}
    choice = gcv_weight(ne, problem.grid, problem.n_parameters - problem.n_cells)
    return choice.weight, {"selection": "gcv", "gcv": choice.score, "edf": choice.edf}


def solve_dense(problem: Problem, weight: float | None) -> tuple[np.ndarray, dict[str, Any]]:
    """The dense reference: ``min ||A S w - y||^2 + lam ||D mu||^2`` s.t. ``mu >= 0`` by cvxpy + Clarabel.

    ``A S`` is the dense ``problem.measured_regressor``; ``lam`` is GCV's
    choice on the same rows (as the fast path) unless ``weight`` is given.
    """
    import cvxpy as cp

    x = problem.measured_regressor
    y_raw = np.asarray(problem.measured, dtype=float)
    scale = float(np.max(np.abs(y_raw))) or 1.0
    y = y_raw / scale
    ne = NormalEquations(x.T @ x, x.T @ y, float(y @ y), y, scale, x)
    lam, info = _weight(ne, problem, weight)
    n = problem.n_nonneg
    d = difference_matrix(problem.grid)
    mu = cp.Variable(n)          # cell weights (and sign-constrained extra terms)
    free = cp.Variable(problem.n_parameters - n)   # mu0, c_d and free extra terms
    fit = cp.sum_squares(x[:, :n] @ mu + x[:, n:] @ free - y)
    roughness = cp.sum_squares(d @ mu[: problem.n_cells])
    task = cp.Problem(cp.Minimize(fit + lam * roughness), [mu >= 0])
    solve_clarabel(task, "the smooth_nn reference QP")
    w = np.concatenate([np.maximum(mu.value, 0.0), free.value]) * scale
    return w, {"solver": "dense", "weight": lam, **info, "status": task.status}


def solve_normal(problem: Problem, weight: float | None) -> tuple[np.ndarray, dict[str, Any]]:
    """The ``"normal"`` algorithm: returns ``w`` (cells, mu0[, c_d]) and diagnostics."""
    n = problem.n_nonneg
    ne = normal_equations(problem)
    lam, info = _weight(ne, problem, weight)
    h, g = ne.hessian, ne.gradient
    r = _padded(dense_roughness_matrix(problem.grid), n)
    # eliminate the free parameters: f = H_ff^+ (g_f - H_fc mu)
    h_ff_pinv = np.linalg.pinv(h[n:, n:], hermitian=True)
    coupling = h_ff_pinv @ h[n:, :n]
    q = h[:n, :n] - h[:n, n:] @ coupling + lam * r
    c = g[:n] - h[:n, n:] @ (h_ff_pinv @ g[n:])
    scale = float(np.max(np.diag(h), initial=0.0)) + lam * float(np.max(np.diag(r), initial=0.0))
    qp = nonneg_qp(q, c, scale)
    w = np.concatenate([qp.x, h_ff_pinv @ g[n:] - coupling @ qp.x])
    if qp.factor is not None:
        w = _refine(problem, ne, r, lam, w, qp, h_ff_pinv, coupling)
    return w * ne.scale, {"solver": "fast", "algorithm": "normal", "weight": lam, **info, **qp.info()}


def _padded(r: np.ndarray, n: int) -> np.ndarray:
    """The cells' roughness matrix ``r`` with zero rows and columns for the sign-constrained extra terms, ``(n, n)``."""
    if r.shape[0] == n:
        return r
    out = np.zeros((n, n))
    out[: r.shape[0], : r.shape[0]] = r
    return out


def _refine(problem, ne, r, lam, w, qp, h_ff_pinv, coupling) -> np.ndarray:
    """Iterative refinement on the cells the QP left free (and mu0, c_d).

    The residual of the optimality conditions is computed from operator
    products ``S^T (A^T (y - A S w))``, not from ``H``, so each step recovers
    the accuracy that forming ``H = (A S)^T (A S)`` lost.  The correction
    reuses the QP's last factorisation (free parameters eliminated as in
    the QP).
    """
    n = problem.n_nonneg
    free = np.flatnonzero(qp.free)
    op, rows = problem.operator, problem.rows
    h_cf = ne.hessian[:n, n:]
    for _ in range(REFINEMENT_STEPS):
        resid = np.zeros(problem.n_rows)
        resid[rows] = ne.y - np.asarray(op.matvec(w)).ravel()[rows]
        grad = np.asarray(op.rmatvec(resid)).ravel()
        grad[:n] -= lam * (r @ w[:n])
        f0 = h_ff_pinv @ grad[n:]
        step = np.zeros(n)
        step[free] = qp.factor.solve((grad[:n] - h_cf @ f0)[free])
        trial = w + np.concatenate([step, f0 - coupling @ step])
        if np.any(trial[:n] < 0):  # the correction must not leave the feasible set
            break
        w = trial
    return w
