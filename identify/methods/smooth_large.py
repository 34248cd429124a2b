"""The matrix-free solver of ``smooth_nn`` for large grids.

Minimises ``1/2 ||A S w - y||^2 + lam/2 ||D mu||^2`` with ``mu >= 0`` by
L-BFGS-B (bounds on the cells, ``mu0`` and ``c_d`` free) using only
``problem.operator`` products and the sparse ``D``: memory ``O(n + P)``, each
iteration one ``S w`` and one ``S^T r``.

Without a given weight, ``lam`` is chosen on held-out measured rows (one
fold of :data:`FOLDS`, every ``FOLDS``-th measured row in time order, so no
randomness): a path of weights from large to small, each fit warm-started
from the last, stops once the held-out error has risen for
:data:`PATIENCE` steps; the best weight is then refitted on every measured
row.  (The ``"normal"`` solver chooses by GCV instead; both use the
measured data only.)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .problem import Problem
from .triangle_penalty import roughness_matrix

FOLDS = 5
PATIENCE = 2
#: Weight path: ``scale * 10**(TOP - STEP * k)`` for ``k = 0 .. STEPS - 1``.
TOP, STEP, STEPS = 2.0, 0.5, 21
PATH_ITERATIONS, FINAL_ITERATIONS = 300, 3000
#: Correction pairs L-BFGS-B keeps.
MEMORY = 20


class _Objective:
    """``1/2 ||X w - y||^2 + lam/2 mu^T R mu`` on the rows ``rows``, with gradient."""

    def __init__(self, problem: Problem, rows: np.ndarray, y: np.ndarray, col_scale: np.ndarray):
        self.op = problem.operator
        self.n = problem.n_rows
        self.n_cells = problem.n_cells
        self.rows = rows
        self.y = y
        self.col_scale = col_scale
        self.r = roughness_matrix(problem.grid)
        self.lam = 0.0

    def __call__(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        w = z * self.col_scale
        resid = np.asarray(self.op.matvec(w)).ravel()[self.rows] - self.y
        full = np.zeros(self.n)
        full[self.rows] = resid
        grad = np.asarray(self.op.rmatvec(full)).ravel()
        mu = w[: self.n_cells]
        rmu = self.r @ mu
        grad[: self.n_cells] += self.lam * rmu
        value = 0.5 * float(resid @ resid) + 0.5 * self.lam * float(mu @ rmu)
        return value, grad * self.col_scale


def _minimise(obj: _Objective, z0: np.ndarray, bounds, iterations: int, gtol: float):
    import scipy.optimize  # imported here: about 0.1 s that the command's start-up need not pay

    res = scipy.optimize.minimize(
        obj, z0, jac=True, method="L-BFGS-B", bounds=bounds,
        options={"maxiter": iterations, "maxcor": MEMORY, "ftol": 1e-13, "gtol": gtol},
    )
    return res.x, res


def solve_iterative(problem: Problem, weight: float | None) -> tuple[np.ndarray, dict[str, Any]]:
    """Returns ``w`` (cells, mu0[, c_d]) and diagnostics (weight, iterations, path)."""
    y_raw = np.asarray(problem.measured, dtype=float)
    scale = float(np.max(np.abs(y_raw))) or 1.0
    y = y_raw / scale
    rows = problem.rows
    n, p = problem.n_nonneg, problem.n_parameters
    op = problem.operator
    # the columns that are not cells (ones, v, effect terms) are rescaled to the size of a cell column
    col_scale = np.ones(p)
    for k in range(problem.n_cells, p):
        e = np.zeros(p)
        e[k] = 1.0
        norm = float(np.linalg.norm(np.asarray(op.matvec(e)).ravel()[rows]))
        col_scale[k] = np.sqrt(rows.size) / norm if norm > 0 else 1.0
    bounds = [(0.0, None)] * n + [(None, None)] * (p - n)
    full = np.zeros(problem.n_rows)
    full[rows] = y
    gtol = 1e-9 * max(1.0, float(np.abs(np.asarray(op.rmatvec(full))).max()))
    data_scale = cell_column_scale(problem)
    z = np.zeros(p)
    iterations = 0
    info: dict[str, Any] = {"solver": "fast", "algorithm": "iterative"}
    if weight is None:
        held = held_out_rows(rows.size)
        lam, z, used, path = _hold_out_path(problem, rows, y, held, col_scale, bounds, gtol, data_scale)
        iterations += used
        info.update(selection="hold-out", path=path)
    else:
        lam = float(weight)
        info["selection"] = "given"
    obj = _Objective(problem, rows, y, col_scale)
    obj.lam = lam
    z, res = _minimise(obj, z, bounds, FINAL_ITERATIONS, gtol)
    iterations += int(res.nit)
    w = z * col_scale * scale
    w[:n] = np.clip(w[:n], 0.0, None)
    info.update(weight=lam, iterations=iterations, converged=bool(res.success))
    return w, info


def cell_column_scale(problem: Problem) -> float:
    """Mean squared norm of the cell columns of ``A S`` (estimated from four random sign
    probes, fixed seed): the data term's scale, which the weight path starts from."""
    n, p = problem.n_cells, problem.n_parameters
    probe = np.random.default_rng(0).choice([-1.0, 1.0], size=(n, 4))
    probe_full = np.vstack([probe, np.zeros((p - n, 4))])
    return float(np.sum(np.asarray(problem.operator.matmat(probe_full))[problem.rows] ** 2)) / (4 * n)


def held_out_rows(m: int) -> np.ndarray:
    """Mask of the held-out measured rows: every :data:`FOLDS`-th, none when that leaves nothing to fit."""
    held = np.arange(m) % FOLDS == 0
    if held.all() or not held.any():
        held = np.zeros(m, dtype=bool)
    return held


def path_weights(data_scale: float):
    """The candidate weights, largest first: ``data_scale * 10**(TOP - STEP k)``."""
    return data_scale * 10.0 ** (TOP - STEP * np.arange(STEPS))


def _hold_out_path(problem, rows, y, held, col_scale, bounds, gtol, data_scale):
    obj = _Objective(problem, rows[~held], y[~held], col_scale)
    z = np.zeros(col_scale.size)
    best = (np.inf, None, z)
    worse, used, path = 0, 0, []
    for lam in path_weights(data_scale):
        obj.lam = float(lam)
        z, res = _minimise(obj, z, bounds, PATH_ITERATIONS, gtol)
        used += int(res.nit)
        pred = np.asarray(problem.operator.matvec(z * col_scale)).ravel()[rows[held]]
        err = float(np.sqrt(np.mean((pred - y[held]) ** 2))) if held.any() else 0.0
        path.append([obj.lam, err])
        if err < best[0]:
            best, worse = (err, obj.lam, z.copy()), 0
        else:
            worse += 1
            if worse >= PATIENCE:
                break
    return best[1], best[2], used, path
