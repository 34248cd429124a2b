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

:func:`nnls_operator` runs Lawson-Hanson for a matrix-free ``S``.  Its
answer is defined by the pivoting when the minimiser is not unique, so it
keeps the algorithm and changes only how the steps are computed:

* small problems (the dense side ``min(M, P) x P'`` of the split problem at
  most :data:`DENSE_LH_ENTRIES`): scipy's NNLS on the ``M`` measured rows of
  ``S`` built from the operator (``M <= P``), or on a ``P x P`` factor ``R``
  with ``R^T R = (A S)^T (A S)`` (``M > P``; Lawson-Hanson takes the same
  steps on ``(R, z)`` with ``R^T z = (A S)^T y`` as on ``(A S, y)``) -- the
  dense reference's own code;
* larger tall ones (``M > P``, ``P^2`` at most :data:`GRAM_LH_ENTRIES`):
  :func:`~.lawson_hanson.lawson_hanson` on ``(R, z)`` (:func:`_nnls_on_factor`),
  ``O(P k)`` a step instead of ``O(M k)``;
* the rest (``M <= P``, or L > 100): :func:`~.lawson_hanson.lawson_hanson`
  on the operator itself -- the same path with the passive columns' thin QR
  factor updated one column at a time, two operator products and ``O(M k)``
  work per step for ``k`` passive columns.  No dense block of ``S`` at
  all, so it also runs where ``M x P`` would not fit (L = 200).

The Gram matrix is not accumulated from products with ``S`` (``O(n P)``
each way): the memory state at a measured row has a few non-zero terms,
so :meth:`~identify.operators.RegressorOperator.gram` forms ``(A S)^T (A S)``
as a sparse product and the prefix sums' adjoint on both sides -- 0.1 s
for the 42,000 measured rows of the FORC session at L = 30.

Ties.  On the Preisach rows the largest gradient is often shared exactly
by two columns (their difference lies in the span of the passive ones).
Lawson-Hanson's rule gives it to the first in its order; scipy's NNLS,
which computes the gradient in a Householder-transformed frame, gives it
to whichever the rounding favours, and so do two correct implementations
that round differently.  The minimiser is the same (the residual agrees to
rounding) but the basic solution, and with it the modelling error, is not:
see the README (*Speed and scale*) for how far apart such solutions are.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..operators import RegressorOperator
from .lawson_hanson import lawson_hanson

#: Largest dense side (entries) of the split problem that scipy's NNLS is given; above it
#: the operator path runs (the two break even near L = 45 on the benchmark's design).
DENSE_LH_ENTRIES = 500_000
#: Largest Gram matrix (``P^2`` entries) that a tall problem above :data:`DENSE_LH_ENTRIES` is reduced to
#: for Lawson-Hanson (:func:`_nnls_on_factor`); above it (L > 100) Lawson-Hanson runs on the operator.
GRAM_LH_ENTRIES = 25_000_000
#: Gradient entries below this many rounding errors of ``X^T r`` do not enter the passive set.
GRADIENT_ULPS = 1000


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
    import scipy.optimize  # imported here: about 0.1 s that the command's start-up need not pay

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
    split = 2 * P - n_nonneg
    if min(rows.size, P) * split <= DENSE_LH_ENTRIES:
        if rows.size <= P:
            w, info = nnls_free(operator.dense_rows(rows), y, n_nonneg)
            return w, {**info, "reduced": False, "path": "measured rows"}
        r, z = _gram_factor(operator, rows, y)
        w, _ = nnls_free(r, z, n_nonneg)
        residual = operator.matvec(w)[rows] - y
        return w, {"residual_norm": float(np.linalg.norm(residual)), "reduced": True, "path": "gram factor"}
    if rows.size > P and P * P <= GRAM_LH_ENTRIES:
        return _nnls_on_factor(operator, rows, y, n_nonneg)
    return _nnls_on_operator(operator, rows, y, n_nonneg)


def _split_products(matvec, rmatvec, P: int, n_nonneg: int):
    """Products with ``[G, F, -F]`` from products with ``[G, F]`` (``P`` columns, the first ``n_nonneg`` G's)."""

    def split_matvec(x):
        w = x[:P].copy()
        w[n_nonneg:] -= x[P:]
        return matvec(w)

    def split_rmatvec(r):
        g = rmatvec(r)
        return np.concatenate([g, -g[n_nonneg:]])

    return split_matvec, split_rmatvec


def _gradient_tol(operator, rows: np.ndarray, b: np.ndarray, n_nonneg: int) -> float:
    """What a gradient entry must exceed to enter: :data:`GRADIENT_ULPS` rounding errors of ``X^T r``."""
    # entries of S are at most 1 (cells, mu0) or |v| (c_d)
    free = operator.shape[1] - n_nonneg
    inputs = operator.inputs[rows[rows < operator.inputs.size]]
    largest = max(1.0, float(np.max(np.abs(inputs), initial=0.0))) if free else 1.0
    return GRADIENT_ULPS * np.finfo(float).eps * np.sqrt(rows.size) * largest * float(np.linalg.norm(b))


def _nnls_on_factor(operator: RegressorOperator, rows: np.ndarray, y: np.ndarray, n_nonneg: int):
    """Lawson-Hanson on ``(R, z)`` (:func:`_gram_factor`) for a tall ``A S`` (``M > P``).

    The same path as :func:`_nnls_on_operator`: the gradients ``R^T (z - R x) = (A S)^T (y - A S x)``,
    the passive columns' norms and their inner products are those of ``A S``, so each step takes the
    same decision -- with products of ``O(P^2)`` and a thin QR of ``P`` rows instead of ``M``.
    """
    P = operator.shape[1]
    free = P - n_nonneg
    scale = float(np.max(np.abs(y))) or 1.0
    tol = _gradient_tol(operator, rows, y / scale, n_nonneg)
    r, z = _gram_factor(operator, rows, y / scale)
    matvec, rmatvec = _split_products(lambda w: r @ w, lambda v: r.T @ v, P, n_nonneg)
    columns = np.asfortranarray(np.hstack([r, -r[:, n_nonneg:]]))  # [G, F, -F] on the factor: P x (P + free)
    result = lawson_hanson(matvec, rmatvec, P + free, z, tol=tol, max_iter=50 * (P + free),
                           column=lambda j: columns[:, j])
    return _unsplit(result, P, n_nonneg, scale, operator, rows, y, reduced=True, path="gram factor lh")


def _nnls_on_operator(operator: RegressorOperator, rows: np.ndarray, y: np.ndarray, n_nonneg: int):
    """Lawson-Hanson on ``[G, F, -F]`` given as products with the operator."""
    n, P = operator.shape
    free = P - n_nonneg
    scale = float(np.max(np.abs(y))) or 1.0
    b = y / scale

    def rows_rmatvec(r):
        full = np.zeros(n)
        full[rows] = r
        return operator.rmatvec(full)

    matvec, rmatvec = _split_products(lambda w: operator.matvec(w)[rows], rows_rmatvec, P, n_nonneg)
    tol = _gradient_tol(operator, rows, b, n_nonneg)
    result = lawson_hanson(matvec, rmatvec, P + free, b, tol=tol, max_iter=50 * (P + free))
    return _unsplit(result, P, n_nonneg, scale, operator, rows, y, reduced=False, path="operator")


def _unsplit(result, P: int, n_nonneg: int, scale: float, operator: RegressorOperator, rows: np.ndarray,
             y: np.ndarray, *, reduced: bool, path: str) -> tuple[np.ndarray, dict]:
    """The weights ``(P,)`` from Lawson-Hanson's answer on ``[G, F, -F]`` (scaled by ``scale``), and the info."""
    w = result.x[:P].copy()
    w[n_nonneg:] -= result.x[P:]
    w *= scale
    residual = operator.matvec(w)[rows] - y
    return w, {
        "residual_norm": float(np.linalg.norm(residual)), "reduced": reduced, "path": path,
        "entered": result.entered, "removed": result.removed, "rejected": result.rejected,
    }


def _gram_factor(operator: RegressorOperator, rows: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``R`` ``(P, P)`` and ``z`` with ``R^T R = (A S)^T A S`` and ``R^T z = (A S)^T y``.

    The Gram matrix from the operator's :meth:`~identify.operators.RegressorOperator.gram` (sparse memory
    states at the measured rows), ``(A S)^T y`` from one product.
    """
    n = operator.shape[0]
    gram = operator.gram(rows)
    gram = (gram + gram.T) / 2.0
    full = np.zeros(n)
    full[rows] = y
    rhs = operator.rmatvec(full)
    try:
        r = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
        z = scipy.linalg.solve_triangular(r, rhs, trans="T", check_finite=False)
    except np.linalg.LinAlgError:  # rank-deficient A S: any square root of the Gram matrix will do
        r, z = _pivoted_factor(gram, rhs)
    return r, z


def _pivoted_factor(gram: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``R`` ``(k, P)`` and ``z`` ``(k,)`` with ``R^T R = gram`` and ``R^T z = rhs`` for a positive
    semi-definite ``gram`` of rank ``k``, ``rhs`` in its range: LAPACK's Cholesky with complete pivoting
    (``?pstrf``, stopping at a pivot below ``P`` rounding errors of the largest diagonal entry), a tenth of
    the time of an eigendecomposition at ``P`` = 467 -- the FORC fits' Gram matrices are rank-deficient
    (cells no input reaches), and a joint fit factors one per linear solve."""
    c, piv, rank, info = scipy.linalg.lapack.dpstrf(gram, tol=-1.0, lower=0)
    if info < 0:
        raise np.linalg.LinAlgError(f"dpstrf: argument {-info} is invalid")
    order = piv - 1
    top = np.triu(c[:rank])
    r = np.empty((rank, gram.shape[0]))
    r[:, order] = top
    z = scipy.linalg.solve_triangular(top[:, :rank], rhs[order[:rank]], trans="T", check_finite=False)
    return r, z
