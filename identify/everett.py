"""The Everett function of a density, and a memory curve's output as Everett terms.

Every output of a Preisach model is a few evaluations of one function of the
density, so the regressor ``S`` never has to be formed (issue 8).

Everett function
----------------
In grid coordinates (walls at the integers, see :mod:`identify.grid`) the
cell weights ``mu_ij`` define a piecewise-constant density
``rho = mu_ij / area_ij`` on the Preisach triangle.  For ``0 <= y <= x <= L``
let::

    F(x, y) = integral of rho over {beta <= alpha, alpha < x, beta < y}

(um).  At the integer points ``F`` is a two-dimensional prefix sum of the
cell weights, the *prefix table*: entry ``c`` of ``p = prefix_sums(mu)`` is
``F(i_c + 1, j_c + 1)`` for the cell ``(i_c, j_c)``, so ``p`` and ``mu`` are
vectors of the same length related by a triangular map whose inverse is a
four-point difference.  Between the integers ``F`` is the bilinear
interpolation of the table plus one correction for the diagonal triangle the
point ``(x, y)`` lies in (the triangle's area is quadratic, not bilinear)::

    F(x, y) = bilinear(P; x, y) + mu_JJ fy (min(x - J, 1) - fy),
    J = floor(y), fy = y - J,  mu_JJ = P[J+1, J+1] - P[J+1, J]

so each ``F(x, y)`` is a fixed combination of at most six table entries.

The output as Everett terms
---------------------------
The +1 region of a memory curve with corners ``(a_k, b_k)`` (see
:mod:`identify.memory`) is the union of the bands
``{a_{k+1} <= alpha < a_k, beta < b_k}`` (``a_K = 0``), so the weight of the
switched-up hysterons is::

    Phi = sum_k F(a_k, b_k) - F(a_k, b_{k-1})          (b_{-1} = 0)

and the Preisach term of equation (22) is
``sum_ij mu_ij s_ij = 2 Phi - sum_ij mu_ij``.  Each corner contributes two
terms that depend on it and its predecessor only, and one input sample
changes the corners from some index on (the wiping-out property), so the
*change* of ``Phi`` at a sample is a handful of terms: every corner is
created once and removed at most once, so there are at most about four
terms per sample over any input sequence, however long its memory.

:func:`everett_increments` records those changes as a sparse matrix ``E``
(``n x n_cells``, at most six entries per term) acting on the prefix table:
``Phi(n) = sum_{m <= n} (E p)_m``.  That gives ``S w`` and ``S^T r`` in
``O(n + L^2)`` time and memory for any input sequence
(:mod:`identify.operators`).
"""

from __future__ import annotations

import bisect
import math
from functools import lru_cache

import numpy as np
import scipy.sparse

from .grid import Grid
from .memory import MemoryCurve


# ------------------------------------------------------------------ prefix table
def _running_sum(table: np.ndarray, axis: int) -> None:
    """In-place cumulative sum along ``axis`` (0 or 1) of an ``(L, L[, k])`` table.

    With many columns ``k`` a loop of row additions is several times faster
    than ``np.cumsum`` along a leading axis (which walks memory with a
    large stride).
    """
    if table.ndim < 3 or table.shape[2] < 16:
        np.cumsum(table, axis=axis, out=table)
        return
    rows = np.moveaxis(table, axis, 0)
    for i in range(1, rows.shape[0]):
        rows[i] += rows[i - 1]


def _summed(grid: Grid, values: np.ndarray, suffix: bool) -> np.ndarray:
    """Prefix (or, with ``suffix``, suffix) sums over the ``(L, L)`` table of cell values."""
    values = np.asarray(values, dtype=float)
    L = grid.levels
    cells = _flat_cells(L)
    flat = np.zeros((L * L,) + values.shape[1:])
    flat[cells] = values
    table = flat.reshape((L, L) + values.shape[1:])  # a view: sums land in ``flat``
    if suffix:
        table = table[::-1, ::-1]
    _running_sum(table, 0)
    _running_sum(table, 1)
    return flat[cells]


def prefix_sums(grid: Grid, density: np.ndarray) -> np.ndarray:
    """The prefix table ``p`` of cell weights ``density``, both ``(n_cells,)`` (um).

    ``p[c] = sum of density over the cells (i, j) with i <= i_c and j <= j_c``.
    Also works column-wise on ``(n_cells, k)`` arrays.
    """
    return _summed(grid, density, suffix=False)


def prefix_sums_adjoint(grid: Grid, g: np.ndarray) -> np.ndarray:
    """The transpose of :func:`prefix_sums` applied to ``g`` ``(n_cells[, k])``.

    Entry ``c`` of the result is the sum of ``g`` over the cells ``(i, j)``
    with ``i >= i_c`` and ``j >= j_c``.
    """
    return _summed(grid, g, suffix=True)


def density_from_prefix(grid: Grid, p: np.ndarray) -> np.ndarray:
    """Inverse of :func:`prefix_sums`: cell weights from the prefix table (four-point differences)."""
    p = np.asarray(p, dtype=float)
    L = grid.levels
    table = np.zeros((L + 1, L + 1) + p.shape[1:])
    table[grid.cell_alpha + 1, grid.cell_beta + 1] = p
    # above the diagonal the table repeats its diagonal: F(x, y) = F(x, x) for y > x
    d = np.arange(L + 1)
    table[d[:-1], d[:-1] + 1] = table[d[:-1], d[:-1]]
    i, j = grid.cell_alpha, grid.cell_beta
    return table[i + 1, j + 1] - table[i, j + 1] - table[i + 1, j] + table[i, j]


def total_index(grid: Grid) -> int:
    """Index in ``p`` of ``F(L, L)``, the sum of every cell weight."""
    return grid.cell_index(grid.levels - 1, grid.levels - 1)


@lru_cache(maxsize=16)
def _flat_cells(levels: int) -> np.ndarray:
    """Flat index ``i L + j`` in an ``(L, L)`` table of every cell, in parameter order."""
    grid = Grid(levels, 0.0, 1.0)
    flat = grid.cell_alpha * levels + grid.cell_beta
    flat.flags.writeable = False
    return flat


@lru_cache(maxsize=16)
def _table_columns(levels: int) -> np.ndarray:
    """``(L+1, L+1)`` map from table point ``(X, Y)`` to its index in ``p`` (-1: ``F = 0``)."""
    grid = Grid(levels, 0.0, 1.0)
    cols = np.full((levels + 1, levels + 1), -1, dtype=np.int64)
    cols[grid.cell_alpha + 1, grid.cell_beta + 1] = np.arange(grid.n_cells)
    for x in range(1, levels + 1):
        cols[x, x + 1 :] = cols[x, x]
    cols.flags.writeable = False
    return cols


def everett_weights(levels: int, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``F(x_t, y_t)`` as combinations of prefix-table entries.

    Parameters
    ----------
    levels: L.
    x, y: ``(T,)`` grid coordinates with ``0 <= y <= x <= L``.

    Returns
    -------
    term, column, weight: ``(6 T,)`` each; ``F(x_t, y_t)`` is the sum of
    ``weight * p[column]`` over the entries with ``term == t``.  Entries of
    weight 0 or on a zero of the table (``column == -1``) are dropped.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    top = levels - 1
    i = np.minimum(np.floor(x), top).astype(np.int64)
    j = np.minimum(np.floor(y), top).astype(np.int64)
    fx = x - i
    fy = y - j
    c = fy * (np.minimum(x - j, 1.0) - fy)  # the diagonal triangle's quadratic area
    cols = _table_columns(levels)
    column = np.concatenate(
        [cols[i, j], cols[i + 1, j], cols[i, j + 1], cols[i + 1, j + 1], cols[j + 1, j + 1], cols[j + 1, j]]
    )
    weight = np.concatenate(
        [(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy, c, -c]
    )
    term = np.tile(np.arange(x.size), 6)
    keep = (column >= 0) & (weight != 0)
    return term[keep], column[keep], weight[keep]


def everett_table(grid: Grid, density: np.ndarray) -> np.ndarray:
    """``F`` at the integer points, ``(L+1, L+1)``: ``table[X, Y] = F(X, min(X, Y))`` (um)."""
    L = grid.levels
    table = np.zeros((L + 1, L + 1))
    table[grid.cell_alpha + 1, grid.cell_beta + 1] = prefix_sums(grid, density)
    for x in range(1, L + 1):
        table[x, x + 1 :] = table[x, x]
    return table


def everett(table, x: float, y: float) -> float:
    """``F(x, y)`` (um) from :func:`everett_table` at one point ``0 <= y <= x <= L`` (grid coordinates).

    ``table`` may be the array or, faster for repeated scalar calls, its
    ``tolist()``.
    """
    top = len(table) - 2
    i = min(int(math.floor(x)), top)
    j = min(int(math.floor(y)), top)
    fx, fy = x - i, y - j
    row_i, row_k = table[i], table[i + 1]
    diagonal = table[j + 1]
    return (
        (1 - fx) * ((1 - fy) * row_i[j] + fy * row_i[j + 1])
        + fx * ((1 - fy) * row_k[j] + fy * row_k[j + 1])
        + fy * (min(x - j, 1.0) - fy) * (diagonal[j + 1] - diagonal[j])
    )


# ------------------------------------------------------------------ memory terms
def everett_terms(curve: MemoryCurve, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The Everett terms by which ``Phi`` changes at each input.

    ``curve`` is the memory before the first input (it is moved through
    ``xs``, grid coordinates); its own corners are counted at sample 0.

    Returns ``(sample, sign, x, y)``, each ``(T,)``: the change of ``Phi`` at
    sample ``n`` is the sum of ``sign * F(x, y)`` over the terms with
    ``sample == n``.  ``T`` is at most about ``4 n`` plus twice the initial
    corners.
    """
    # MemoryCurve.apply's rules inlined (about four times faster than a call per input): a rise to x
    # wipes the corners with a <= x and appends (x, x); a fall to x sets b = x on the first corner with
    # b >= x (b rises along the corners: a bisection) and wipes the later ones, or wipes it at x = 0
    a_list, b_list = list(curve._a), list(curve._b)
    position = curve.position
    sample: list[int] = []
    sign: list[float] = []
    tx: list[float] = []
    ty: list[float] = []
    prev = 0.0
    for a, b in zip(a_list, b_list):  # the initial corners, counted at sample 0
        sample += (0, 0)
        sign += (1.0, -1.0)
        tx += (a, a)
        ty += (b, prev)
        prev = b
    levels = float(curve.levels)
    for n, x in enumerate(np.clip(np.asarray(xs, dtype=float), 0.0, levels).tolist()):
        if x > position:
            k = len(a_list)
            while k and a_list[k - 1] <= x:
                k -= 1
            new_a = x
        elif x < position:
            k = bisect.bisect_left(b_list, x)
            if k == len(b_list):
                position = x
                continue
            new_a = a_list[k] if x > 0.0 else None
        else:
            continue
        position = x
        prev = b_list[k - 1] if k else 0.0
        p = prev
        for i in range(k, len(a_list)):  # the old tail goes
            a, b = a_list[i], b_list[i]
            sample += (n, n)
            sign += (-1.0, 1.0)
            tx += (a, a)
            ty += (b, p)
            p = b
        del a_list[k:], b_list[k:]
        if new_a is not None:  # the new corner comes
            a_list.append(new_a)
            b_list.append(x)
            sample += (n, n)
            sign += (1.0, -1.0)
            tx += (new_a, new_a)
            ty += (x, prev)
    curve._a[:], curve._b[:] = a_list, b_list
    curve.position = position
    return (
        np.asarray(sample, dtype=np.int64),
        np.asarray(sign, dtype=float),
        np.asarray(tx, dtype=float),
        np.asarray(ty, dtype=float),
    )


def everett_increments(grid: Grid, xs: np.ndarray, curve: MemoryCurve) -> scipy.sparse.csr_array:
    """The sparse matrix ``E`` (``n x n_cells``): ``Phi(n) = sum_{m <= n} (E p)_m``.

    ``xs`` are the inputs in grid coordinates (``grid.coordinates(v)``),
    ``curve`` the memory before the first of them (it is moved through
    ``xs``).  ``p`` is the prefix table of the cell weights
    (:func:`prefix_sums`).
    """
    n = len(xs)
    sample, sign, tx, ty = everett_terms(curve, xs)
    term, column, weight = everett_weights(grid.levels, tx, ty)
    return scipy.sparse.csr_array(
        (weight * sign[term], (sample[term], column)), shape=(n, grid.n_cells)
    )
