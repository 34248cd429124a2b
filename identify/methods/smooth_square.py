"""``smooth_nn`` on the square damped-oscillation design, solved in output space.

On that design ``S`` is invertible with a sparse inverse ``T``
(:func:`identify.square.sparse_inverse`, about four non-zeros per row), so
every parameter vector is ``w = T b`` for the outputs ``b = S w`` it
predicts at the applied inputs.  Written in ``b`` the problem of
:mod:`~identify.methods.smooth_nn`::

    min_b  1/2 ||b_A - y||^2 + lam/2 ||D T_c b||^2     s.t.  T_c b >= 0

(``T_c`` the cell rows of ``T``, ``b_A`` the measured outputs) has a
diagonal data term and the sparse penalty ``K = (D T_c)^T (D T_c)`` (about
21 non-zeros per row): no normal equations, no dense ``S`` or ``A S``;
memory ``O(n)`` plus one sparse factor.

* The weight, unless given: up to :data:`GCV_MAX_ROWS` measured rows by
  exact GCV as the ``"normal"`` algorithm: eliminating the unmeasured
  outputs leaves the hat matrix ``(I + lam K_s)^{-1}``, ``K_s`` the Schur
  complement of ``K`` onto the measured outputs, so one ``M x M``
  eigendecomposition scores every candidate weight; above that on held-out
  measured rows like the ``"iterative"`` algorithm (same folds and weight
  path), each candidate one sparse factorisation of ``diag(a) + lam K``
  for the unconstrained fit (the weight is chosen without the sign
  constraint, as GCV's is).
* The non-negative QP: Clarabel's interior point on the sparse problem
  above (``n`` variables, ``n_cells`` linear constraints).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from ..errors import IdentifyError
from .gcv import choose, curve_from_spectrum
from .output_space import SPD_LU, _run
from .problem import Problem
from .smooth_large import PATIENCE, cell_column_scale, held_out_rows, path_weights
from .triangle_penalty import difference_matrix

#: Exact GCV (an ``M x M`` eigendecomposition) up to this many measured rows; hold-out above.
GCV_MAX_ROWS = 2048


def solve_outputs(problem: Problem, weight: float | None) -> tuple[np.ndarray, dict[str, Any]]:
    """Returns ``w`` (cells, mu0[, c_d]) and diagnostics; ``problem`` must be the square design."""
    inverse = problem.sparse_inverse
    n, cells = problem.n, problem.n_cells
    t_cells = scipy.sparse.csr_array(inverse[:cells])
    dt = scipy.sparse.csr_array(difference_matrix(problem.grid) @ t_cells)
    penalty = scipy.sparse.csc_array(dt.T @ dt)
    y_raw = np.asarray(problem.measured, dtype=float)
    scale = float(np.max(np.abs(y_raw))) or 1.0
    y = y_raw / scale
    rows = problem.rows
    info: dict[str, Any] = {"solver": "fast", "algorithm": "outputs"}
    if weight is not None:
        lam = float(weight)
        info["selection"] = "given"
    elif rows.size <= GCV_MAX_ROWS:
        choice = _gcv(penalty, rows, y)
        lam = choice.weight
        info.update(selection="gcv", gcv=choice.score, edf=choice.edf)
    else:
        lam, path = _hold_out(problem, penalty, y)
        info.update(selection="hold-out", path=path)
    data = np.zeros(n)
    data[rows] = 1.0
    target = np.zeros(n)
    target[rows] = y
    hessian = scipy.sparse.triu(scipy.sparse.diags_array(data) + lam * penalty, format="csc")
    b, _, qp = _run(hessian, -target, -t_cells, np.zeros(cells), cells)
    w = (inverse @ b) * scale
    w[:cells] = np.maximum(w[:cells], 0.0)
    return w, {**info, "weight": lam, **qp}


def _gcv(penalty: scipy.sparse.csc_array, rows: np.ndarray, y: np.ndarray):
    """GCV's weight from the Schur complement of the penalty onto the measured outputs."""
    k = penalty.toarray()
    other = np.setdiff1d(np.arange(k.shape[0]), rows)
    k_s = k[np.ix_(rows, rows)]
    if other.size:
        coupling = k[np.ix_(other, rows)]
        try:
            k_s = k_s - coupling.T @ scipy.linalg.solve(k[np.ix_(other, other)], coupling, assume_a="pos")
        except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
            raise IdentifyError(
                "smooth_nn: the unmeasured outputs leave a direction the roughness penalty does not "
                "see; give a weight"
            ) from None
    values, vectors = scipy.linalg.eigh(0.5 * (k_s + k_s.T), driver="evd", check_finite=False)
    tol = max(float(values.max(initial=0.0)), np.finfo(float).tiny) * values.size * np.finfo(float).eps * 16
    penalised = values > tol
    c2 = (vectors[:, penalised].T @ y) ** 2
    # ridge form: shrink factor 1 / (1 + lam k) = s / (s + lam) with s = 1 / k
    curve = curve_from_spectrum(1.0 / values[penalised], c2, 0.0, int(np.sum(~penalised)), "data", rows.size)
    return choose(curve)


def _hold_out(problem: Problem, penalty: scipy.sparse.csc_array, y: np.ndarray):
    """The path weight whose unconstrained fit on the training rows best predicts the held-out ones."""
    rows = problem.rows
    held = held_out_rows(rows.size)
    train = np.zeros(problem.n)
    train[rows[~held]] = 1.0
    target = np.zeros(problem.n)
    target[rows[~held]] = y[~held]
    best, worse, path = (np.inf, None), 0, []
    for lam in path_weights(cell_column_scale(problem)):
        try:
            lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(scipy.sparse.diags_array(train) + lam * penalty), **SPD_LU)
        except RuntimeError:  # singular: the training rows leave a direction free
            continue
        b = lu.solve(target)
        err = float(np.sqrt(np.mean((b[rows[held]] - y[held]) ** 2))) if held.any() else 0.0
        path.append([float(lam), err])
        if err < best[0]:
            best, worse = (err, float(lam)), 0
        else:
            worse += 1
            if worse >= PATIENCE:
                break
    if best[1] is None:
        raise IdentifyError("smooth_nn: no candidate weight gave a solvable fit; give a weight")
    return best[1], path
