"""Non-negative least squares with some free (sign-unconstrained) columns.

The Preisach density must be >= 0 while the bias ``mu0`` and the thermal
coefficient ``c_d`` are free.  Each free variable is split into a positive
and a negative part, ``f = f+ - f-``, and Lawson-Hanson NNLS (Matlab's
``lsqnonneg``, the paper's 'Least Squares') is run on ``[G, F, -F]``.

With fewer measurements than parameters the minimiser is not unique; the
active-set method returns a basic solution (linearly independent active
columns), which stays bounded even when a cell's column is constant over
the measured rows and so indistinguishable from the bias.  Eliminating the
free columns by projection instead leaves such a column as rounding noise
(~1e-16) that NNLS then weights by ~1e12.

:func:`nnls_operator` runs the same Lawson-Hanson iteration for a
matrix-free ``S``.  Its answer is defined by the pivoting when the
minimiser is not unique, so it keeps the algorithm and changes only what
it is fed: with ``M <= P`` the ``M`` measured rows of ``S`` built from the
operator (never the dense ``S``), with ``M > P`` a ``P x P`` factor ``R``
with ``R^T R = (A S)^T (A S)`` accumulated from operator products a block
of columns at a time.  Lawson-Hanson takes the same steps on ``(R, z)``
with ``R^T z = (A S)^T y`` as on ``(A S, y)`` -- its gradients and
passive-set least-squares solutions are the same -- in ``O(P^2)`` memory
however many rows were measured.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.optimize

from ..errors import IdentifyError
from ..operators import RegressorOperator

#: Largest dense block (bytes) the fast Lawson-Hanson path builds: the M x P measured rows
#: of S (Lawson-Hanson works on a copy, so the peak is about twice this).
MAX_DENSE_BYTES = 2**30


def nnls_free(a: np.ndarray, y: np.ndarray, n_nonneg: int) -> tuple[np.ndarray, dict]:
    """``argmin ||a w - y||_2`` with ``w[:n_nonneg] >= 0`` and the rest free.

    Parameters
    ----------
    a: ``(M, P)`` matrix.
    y: ``(M,)`` right-hand side.
    n_nonneg: how many leading entries of ``w`` are constrained to be >= 0.

    Returns
    -------
    w: ``(P,)`` solution; info: residual norm.
    """
    a = np.asarray(a, dtype=float)
    y = np.asarray(y, dtype=float)
    p = a.shape[1]
    scale = float(np.max(np.abs(y))) or 1.0
    augmented = np.hstack([a, -a[:, n_nonneg:]])
    x, _ = scipy.optimize.nnls(augmented, y / scale, maxiter=50 * augmented.shape[1])
    w = x[:p].copy()
    w[n_nonneg:] -= x[p:]
    w *= scale
    return w, {"residual_norm": float(np.linalg.norm(a @ w - y))}


def nnls_operator(
    operator: RegressorOperator, rows: np.ndarray, y: np.ndarray, n_nonneg: int
) -> tuple[np.ndarray, dict]:
    """:func:`nnls_free` for ``a = (rows of the operator)`` without the dense ``S``.

    ``rows``: ``(M,)`` sorted measured rows; ``y``: ``(M,)`` their outputs.
    """
    rows = np.asarray(rows, dtype=np.int64)
    y = np.asarray(y, dtype=float)
    P = operator.shape[1]
    if rows.size <= P:
        need = 8 * rows.size * P
        if need > MAX_DENSE_BYTES:
            raise IdentifyError(
                f"Lawson-Hanson on {rows.size} measured rows and {P} parameters needs their "
                f"{rows.size} x {P} block of S ({need / 2**30:.1f} GB, limit "
                f"{MAX_DENSE_BYTES / 2**30:.0f} GB) and about M P operations per pivot; "
                "use fewer levels or a method for the damped oscillation (cs_order_nn)"
            )
        w, info = nnls_free(operator.dense_rows(rows), y, n_nonneg)
        return w, {**info, "reduced": False}
    r, z = _gram_factor(operator, rows, y)
    w, _ = nnls_free(r, z, n_nonneg)
    residual = operator.matvec(w)[rows] - y
    return w, {"residual_norm": float(np.linalg.norm(residual)), "reduced": True}


def _gram_factor(operator: RegressorOperator, rows: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``R`` ``(P, P)`` and ``z`` with ``R^T R = (A S)^T A S`` and ``R^T z = (A S)^T y``."""
    n, P = operator.shape
    mask = np.zeros(n)
    mask[rows] = 1.0
    gram = np.empty((P, P))
    block = max(1, 8_000_000 // max(n, 1))
    for start in range(0, P, block):
        stop = min(P, start + block)
        e = np.zeros((P, stop - start))
        e[np.arange(start, stop), np.arange(stop - start)] = 1.0
        gram[:, start:stop] = operator.rmatmat(operator.matmat(e) * mask[:, None])
    gram = (gram + gram.T) / 2.0
    full = np.zeros(n)
    full[rows] = y
    rhs = operator.rmatvec(full)
    try:
        r = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
        z = scipy.linalg.solve_triangular(r, rhs, trans="T", check_finite=False)
    except np.linalg.LinAlgError:  # rank-deficient A S: any square root of the Gram matrix will do
        lam, vec = scipy.linalg.eigh(gram, check_finite=False)
        keep = lam > lam.max() * 1e-14
        r = np.sqrt(lam[keep])[:, None] * vec[:, keep].T
        z = (vec[:, keep].T @ rhs) / np.sqrt(lam[keep])
    return r, z
