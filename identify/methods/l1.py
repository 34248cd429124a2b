"""Dense reference l1 solvers (cvxpy + Clarabel) for the compressive methods.

Written to read like the paper's equations; the right-hand side is scaled to
unit size before solving and the solution scaled back, so the solver's
tolerances mean the same thing whatever the output units.  cvxpy is
imported on first use: only the dense path needs it (about a second).
"""

from __future__ import annotations

import numpy as np

from ..errors import IdentifyError


def _solve(problem) -> dict:
    import cvxpy as cp

    try:
        problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError as exc:  # pragma: no cover - solver failure
        raise IdentifyError(f"the l1 solver failed: {exc}") from None
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise IdentifyError(f"the l1 problem is {problem.status}")
    stats = problem.solver_stats
    return {"status": problem.status, "iterations": getattr(stats, "num_iters", None)}


def basis_pursuit(
    phi: np.ndarray, y: np.ndarray, epsilon: float | None = None, free: int = 0
) -> tuple[np.ndarray, dict]:
    """``min ||x[:P-free]||_1`` s.t. ``phi x = y`` (or ``||phi x - y||_2 <= epsilon``).

    Equations (7) and (15): with ``phi = A Psi^{-1}`` and ``x = q`` this is
    'CS'; with ``phi = A S`` and ``x = w`` it is 'CS Without DCT' (then the
    last ``free`` entries, ``mu0`` and ``c_d``, are not penalised).

    Parameters
    ----------
    phi: ``(M, P)`` measurement matrix.
    y: ``(M,)`` measurements, in output units.
    epsilon: noise bound on ``||phi x - y||_2`` in output units, or None for
        the equality-constrained problem.
    """
    import cvxpy as cp

    phi = np.asarray(phi, dtype=float)
    y = np.asarray(y, dtype=float)
    scale = float(np.max(np.abs(y))) or 1.0
    x = cp.Variable(phi.shape[1])
    penalised = x[: phi.shape[1] - free] if free else x
    if epsilon is None:
        constraints = [phi @ x == y / scale]
    else:
        constraints = [cp.norm(phi @ x - y / scale, 2) <= epsilon / scale]
    info = _solve(cp.Problem(cp.Minimize(cp.norm1(penalised)), constraints))
    return np.asarray(x.value) * scale, info
