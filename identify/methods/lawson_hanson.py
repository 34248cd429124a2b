"""Lawson-Hanson NNLS that needs only products with the matrix: the same active-set path, faster.

``argmin ||X x - b||_2`` subject to ``x >= 0`` by the active-set method of
Lawson and Hanson (1974, chapter 23) -- Matlab's ``lsqnonneg`` and
``scipy.optimize.nnls``.  When the minimiser is not unique (fewer rows
than columns) the answer *is* the basic solution the path ends on, so the
path is kept: the entering column is the largest gradient
``w = X^T (b - X x)`` (ties to the first in LH's permuted order of the zero
set), it must pass LH's independence test (a pivot above 100 ulps of the
rest of the column) and sign test, the inner loop steps to the boundary,
removes the first blocking variable in insertion order and then every
variable at or below zero -- the bookkeeping of ``scipy.optimize.nnls``
(its C translation of LH's ``NNLS``) step for step.

What changes is how a step is computed.  LH keeps ``Q^T X`` -- every column
of ``X``, Householder-transformed after every step -- so each step costs
``O(M P)`` however few columns are passive.  Here only the passive
columns' thin QR factorisation ``X_P = Q R`` is kept (``Q`` ``M x k``): a
column enters by classical Gram-Schmidt against ``Q`` with one
reorthogonalisation (orthogonal to rounding, like a Householder step) and
leaves by the Givens rotations LH applies to its triangle, applied to
``Q`` as well.  The gradient comes from the residual ``b - Q Q^T b`` and
one product with ``X^T``; the entering column from one product with
``X``.  A step therefore costs two products and ``O(M k)`` -- with the
matrix-free Preisach operator a product is ``O(n + L^2)``, so at L = 100
the path never touches a dense ``M x P`` block.  The tests in
``tests/test_lawson_hanson.py`` check the path against
``scipy.optimize.nnls`` on problems where it is unique.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.linalg.blas import drot

from ..errors import IdentifyError

#: Gradients within this relative distance of the largest count as tied with it (rounding
#: of ``X^T r``); LH gives a tie to the first candidate in its order.
TIE = 1e-9


class _ThinQR:
    """``X_P = Q R`` for the passive columns: ``Q`` ``(m, k)`` orthonormal, ``R`` ``(k, k)`` upper."""

    def __init__(self, m: int, capacity: int, max_bytes: float) -> None:
        self.m = m
        self.max_bytes = max_bytes
        self.k = 0
        self.q = np.zeros((m, 0), order="F")
        self.r = np.zeros((0, 0))
        self.qtb = np.zeros(0)  # Q^T b
        self._grow(min(capacity, 64))

    def _grow(self, capacity: int) -> None:
        if 8.0 * self.m * capacity > self.max_bytes:
            raise IdentifyError(
                f"Lawson-Hanson's passive set outgrew its memory budget ({capacity} columns of "
                f"{self.m} rows, limit {self.max_bytes / 2**30:.1f} GB)"
            )
        k = self.k
        q = np.zeros((self.m, capacity), order="F")
        q[:, :k] = self.q[:, :k]
        r = np.zeros((capacity, capacity))
        r[:k, :k] = self.r[:k, :k]
        qtb = np.zeros(capacity)
        qtb[:k] = self.qtb[:k]
        self.q, self.r, self.qtb = q, r, qtb

    def project(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Q^T x, x - Q Q^T x)`` by classical Gram-Schmidt, twice."""
        q = self.q[:, : self.k]
        coef = q.T @ x
        rest = x - q @ coef
        again = q.T @ rest
        return coef + again, rest - q @ again

    def residual(self, b: np.ndarray) -> np.ndarray:
        """``b - Q Q^T b``: the residual of the least-squares fit on the passive columns."""
        return b - self.q[:, : self.k] @ self.qtb[: self.k]

    def append(self, coef: np.ndarray, pivot: float, direction: np.ndarray, qtb: float) -> None:
        k = self.k
        if k == self.q.shape[1]:
            self._grow(min(2 * k, self.m))
        self.q[:, k] = direction
        self.r[:k, k] = coef
        self.r[k, : k + 1] = 0.0
        self.r[k, k] = pivot
        self.qtb[k] = qtb
        self.k = k + 1

    def solve(self) -> np.ndarray:
        """The least-squares solution on the passive columns, ``R^{-1} Q^T b``."""
        k = self.k
        return scipy.linalg.solve_triangular(self.r[:k, :k], self.qtb[:k], check_finite=False)

    def remove(self, p: int) -> None:
        """Drop passive position ``p``: shift later columns left and restore the triangle by rotations."""
        k = self.k
        r, q, qtb = self.r, self.q, self.qtb
        r[:k, p : k - 1] = r[:k, p + 1 : k]
        for i in range(p, k - 1):
            c, s = _rotation(r[i, i], r[i + 1, i])
            r[i, i], r[i + 1, i] = np.hypot(r[i, i], r[i + 1, i]), 0.0
            if i + 1 < k - 1:
                r[i, i + 1 : k - 1], r[i + 1, i + 1 : k - 1] = drot(r[i, i + 1 : k - 1], r[i + 1, i + 1 : k - 1], c, s)
            q[:, i], q[:, i + 1] = drot(q[:, i], q[:, i + 1], c, s)
            qtb[i], qtb[i + 1] = c * qtb[i] + s * qtb[i + 1], c * qtb[i + 1] - s * qtb[i]
        r[: k, k - 1] = 0.0
        self.k = k - 1


def _rotation(a: float, b: float) -> tuple[float, float]:
    """``(c, s)`` with ``[c s; -s c] [a; b] = [hypot(a, b); 0]`` (non-negative, as LAPACK's ``dlartgp``)."""
    h = float(np.hypot(a, b))
    return (a / h, b / h) if h > 0 else (1.0, 0.0)


@dataclass(frozen=True)
class LawsonHansonResult:
    """``x`` ``(n,)``; ``passive``: the passive set in LH's order; how many steps of each kind."""

    x: np.ndarray
    passive: np.ndarray
    entered: int
    removed: int
    rejected: int


def lawson_hanson(
    matvec: Callable[[np.ndarray], np.ndarray],
    rmatvec: Callable[[np.ndarray], np.ndarray],
    n: int,
    b: np.ndarray,
    tol: float = 0.0,
    max_iter: int | None = None,
    max_bytes: float = 2**30,
    column: Callable[[int], np.ndarray] | None = None,
) -> LawsonHansonResult:
    """``argmin ||X x - b||_2`` over ``x >= 0`` along Lawson-Hanson's path.

    Parameters
    ----------
    matvec: ``x (n,) -> X x (m,)``.
    rmatvec: ``r (m,) -> X^T r (n,)``.
    n: number of columns of ``X``.
    b: ``(m,)`` right-hand side.
    tol: a gradient entry must exceed this to enter (LH: 0; a few rounding
        errors of ``X^T r`` keep noise from driving extra steps).
    max_iter: inner iterations before giving up (default ``3 n``, as scipy).
    max_bytes: memory budget of ``Q`` (``8 m k`` bytes for ``k`` passive columns).
    column: ``j -> X e_j`` ``(m,)`` where that is cheaper than ``matvec`` of a unit vector (a dense ``X``).

    Raises :class:`IdentifyError` when ``max_iter`` is reached or ``Q``
    would outgrow ``max_bytes``.
    """
    b = np.asarray(b, dtype=float)
    m = b.size
    max_iter = 3 * n if max_iter is None else int(max_iter)
    x = np.zeros(n)
    order = np.arange(n)  # LH's ``indices``: the passive set (insertion order), then the zero set
    qr = _ThinQR(m, min(m, n), max_bytes)
    entered = removed = rejected = iteration = 0
    unit = np.zeros(n)
    while qr.k < min(m, n):
        k = qr.k
        residual = qr.residual(b)
        wz = np.asarray(rmatvec(residual), dtype=float).ravel()[order[k:]]
        while True:
            pos = int(np.argmax(wz))
            if not wz[pos] > tol:
                return LawsonHansonResult(x, order[:k].copy(), entered, removed, rejected)
            pos = int(np.argmax(wz >= wz[pos] * (1.0 - TIE)))
            j = int(order[k + pos])
            if column is None:
                unit[j] = 1.0
                col = np.asarray(matvec(unit), dtype=float).ravel()
                unit[j] = 0.0
            else:
                col = np.asarray(column(j), dtype=float).ravel()
            coef, rest = qr.project(col)
            pivot = float(np.linalg.norm(rest))
            unorm = float(np.linalg.norm(coef))
            if pivot > 100.0 * np.spacing(unorm):  # LH's test for an independent column
                ztest = float(rest @ residual) / pivot**2
                if ztest > 0.0:
                    break
            wz[pos] = 0.0  # LH: reject j, try the next largest gradient
            rejected += 1
        order[k + pos] = order[k]
        order[k] = j
        qr.append(coef, pivot, rest / pivot, ztest * pivot)
        entered += 1
        z = qr.solve()
        while True:  # LH's inner loop: step to the boundary while the solution is infeasible
            iteration += 1
            if iteration >= max_iter:
                raise IdentifyError(f"Lawson-Hanson NNLS did not finish within {max_iter} iterations")
            passive = order[: qr.k]
            blocked = np.flatnonzero(z <= 0.0)
            if blocked.size == 0:
                break
            xp = x[passive]
            ratios = -xp[blocked] / (z[blocked] - xp[blocked])
            first = int(np.argmin(ratios))  # the first minimum in insertion order, as LH
            alpha, leave = ratios[first], int(blocked[first])
            x[passive] = xp + alpha * (z - xp)
            while True:
                i = int(order[leave])
                x[i] = 0.0
                order[leave : qr.k - 1] = order[leave + 1 : qr.k]
                qr.remove(leave)
                order[qr.k] = i
                removed += 1
                low = np.flatnonzero(x[order[: qr.k]] <= 0.0)
                if low.size == 0:
                    break
                leave = int(low[0])
            z = qr.solve()
        x[order[: qr.k]] = z
    return LawsonHansonResult(x, order[: qr.k].copy(), entered, removed, rejected)
