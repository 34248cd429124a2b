"""The normal equations of the measured rows, built from products with ``S`` only.

For measured rows ``A`` (a row selection) and outputs ``y`` (length ``M``)
the least-squares quantities are ``H = (A S)^T (A S)``, ``g = (A S)^T y``
and ``y^T y``.  They are formed from ``problem.operator`` (``S w`` and
``S^T r``) applied to blocks of unit vectors, never from a dense ``S``, so
their cost is ``2 P`` operator products (``P`` parameters) and their memory
``P^2`` plus one ``n x block`` work array, whatever the number ``n`` of
applied inputs.  When ``M P`` is small the measured rows ``A S`` are kept
as a dense ``(M, P)`` matrix instead (``min(M, P)`` products); solvers that
need them (the data-space GCV) use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .problem import Problem

#: Keep ``A S`` explicitly when it has at most this many entries (32 MB).
DENSE_ROWS_LIMIT = 4_000_000
#: Work-array budget (entries) for one block of operator products (64 MB).
BLOCK_ENTRIES = 8_000_000


@dataclass(frozen=True)
class NormalEquations:
    """``H`` ``(P, P)``, ``g`` ``(P,)``, ``yy`` and ``M`` of the scaled measured rows.

    ``rows_matrix`` is ``A S`` ``(M, P)`` when it was kept (small problems),
    else ``None``.  ``y`` is the measured output divided by ``scale``.
    """

    hessian: np.ndarray
    gradient: np.ndarray
    yy: float
    y: np.ndarray
    scale: float
    rows_matrix: np.ndarray | None

    @property
    def n_measured(self) -> int:
        return self.y.size


def _column_blocks(n_rows: int, n_cols: int):
    width = max(1, min(n_cols, BLOCK_ENTRIES // max(n_rows, 1)))
    for start in range(0, n_cols, width):
        yield slice(start, min(start + width, n_cols))


def _unit_block(p: int, cols: slice) -> np.ndarray:
    block = np.zeros((p, cols.stop - cols.start))
    block[np.arange(cols.start, cols.stop), np.arange(block.shape[1])] = 1.0
    return block


def measured_rows_matrix(problem: Problem) -> np.ndarray:
    """``A S``, shape ``(M, P)``, from operator products in blocks.

    ``min(M, P)`` products: ``S^T e_r`` for each measured row ``r`` when
    ``M < P``, else ``S e_k`` for each parameter ``k``.
    """
    op, rows, p, n = problem.operator, problem.rows, problem.n_parameters, problem.n_rows
    out = np.empty((rows.size, p))
    if rows.size < p:
        for block in _column_blocks(max(n, p), rows.size):
            picks = np.zeros((n, block.stop - block.start))
            picks[rows[block], np.arange(picks.shape[1])] = 1.0
            out[block] = np.asarray(op.rmatmat(picks)).T
        return out
    for cols in _column_blocks(n, p):
        out[:, cols] = np.asarray(op.matmat(_unit_block(p, cols)))[rows]
    return out


def normal_equations(problem: Problem, keep_rows: bool | None = None) -> NormalEquations:
    """``H``, ``g``, ``y^T y`` of the measured rows, outputs scaled to unit size.

    ``keep_rows`` forces (True) or forbids (False) keeping ``A S``; by
    default it is kept when it has at most :data:`DENSE_ROWS_LIMIT` entries.
    """
    y_raw = np.asarray(problem.measured, dtype=float)
    scale = float(np.max(np.abs(y_raw))) or 1.0
    y = y_raw / scale
    p, rows, op = problem.n_parameters, problem.rows, problem.operator
    if keep_rows is None:
        keep_rows = rows.size * p <= DENSE_ROWS_LIMIT
    full = np.zeros(problem.n_rows)
    full[rows] = y
    gradient = np.asarray(op.rmatvec(full), dtype=float).ravel()
    if keep_rows:
        x = measured_rows_matrix(problem)
        hessian = x.T @ x
    else:
        x = None
        hessian = np.empty((p, p))
        for cols in _column_blocks(problem.n_rows, p):
            s_cols = np.asarray(op.matmat(_unit_block(p, cols)))
            masked = np.zeros_like(s_cols)
            masked[rows] = s_cols[rows]
            hessian[:, cols] = np.asarray(op.rmatmat(masked))
        hessian = 0.5 * (hessian + hessian.T)
    return NormalEquations(hessian, gradient, float(y @ y), y, scale, x)
