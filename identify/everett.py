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
    cols = _table_columns(levels).ravel()  # flat: a third of the time of two-index lookups
    stride = levels + 1
    at = i * stride + j
    diagonal = (j + 1) * stride + j
    T = x.size
    column = np.empty((6, T), dtype=np.int64)
    np.take(cols, at, out=column[0])
    np.take(cols, at + stride, out=column[1])
    np.take(cols, at + 1, out=column[2])
    np.take(cols, at + stride + 1, out=column[3])
    np.take(cols, diagonal + 1, out=column[4])
    np.take(cols, diagonal, out=column[5])
    gx, gy = 1 - fx, 1 - fy
    weight = np.empty((6, T))
    np.multiply(gx, gy, out=weight[0])
    np.multiply(fx, gy, out=weight[1])
    np.multiply(gx, fy, out=weight[2])
    np.multiply(fx, fy, out=weight[3])
    weight[4] = c
    np.negative(c, out=weight[5])
    keep = np.flatnonzero((column.ravel() >= 0) & (weight.ravel() != 0))
    return keep % T if T else keep, column.ravel().take(keep), weight.ravel().take(keep)


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
    a0, b0 = curve.corners
    if (b0[-1] if b0.size else 0.0) != curve.position or np.any(np.diff(a0) >= 0) or np.any(np.diff(b0) <= 0):
        return _everett_terms_loop(curve, xs)  # a curve no sequence of inputs leads to: follow its rules as they are
    return _everett_terms_vectorised(curve, xs)


def _everett_terms_loop(curve: MemoryCurve, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`everett_terms` one input at a time (the reference of the vectorised replay)."""
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


def _reach_back(table: list[np.ndarray], end: np.ndarray, keep) -> np.ndarray:
    """For each ``end`` ``(k,)``, the earliest ``start <= end`` with ``keep`` true of the sparse ``table``'s
    blocks over all of ``[start, end)`` (``table[j][i]`` summarises ``[i, i + 2^j)``), by halving steps."""
    for j in range(len(table) - 1, -1, -1):
        start = end - (1 << j)
        ok = start >= 0
        end = np.where(ok & keep(table[j][np.where(ok, start, 0)]), start, end)
    return end


def _sparse_table(values: np.ndarray, op) -> list[np.ndarray]:
    """``table[j][i] = op`` over ``values[i : i + 2**j]`` (``len(values) - 2**j + 1`` entries at level ``j``)."""
    table = [values]
    width = 1
    while 2 * width <= values.size:
        prev = table[-1]
        table.append(op(prev[:-width], prev[width:]))
        width *= 2
    return table


def _everett_terms_vectorised(curve: MemoryCurve, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`everett_terms` without a loop over the inputs, the same terms in the same order.

    Every change of the input creates one corner (none at a fall to 0): ``(x, x)`` at a rise, ``(A, x)`` at
    a fall, with ``A`` the largest input since the input was last below ``x``.  The corner lives until
    the input first leaves the open interval ``(x, A)``; its predecessor on the staircase (whose ``b`` its
    second term takes) is the latest earlier corner that outlives its creation.  Each of these is a search
    over the inputs answered for all of them at once with sparse tables of running minima and maxima
    (``O(n log n)``).  The initial corners are the inputs ``0, a_0, b_0, a_1, ...`` before the first,
    their terms counted at sample 0 as the loop counts them.
    """
    levels = float(curve.levels)
    a0, b0 = curve.corners
    prefix = np.concatenate([[0.0], np.column_stack([a0, b0]).ravel()])
    x = np.concatenate([prefix, np.clip(np.asarray(xs, dtype=float), 0.0, levels)])
    origin = np.concatenate([np.zeros(prefix.size, dtype=np.int64), np.arange(x.size - prefix.size)])
    changed = np.concatenate([[True], x[1:] != x[:-1]])
    y, sample = x[changed], origin[changed]
    virtual = int(np.count_nonzero(changed[: prefix.size]))  # steps of the initial corners' inputs
    N = y.size
    steps = np.arange(N)
    empty = np.zeros(0)
    if N < 2:
        curve._a[:], curve._b[:] = [], []
        return np.zeros(0, dtype=np.int64), empty, empty, empty
    low, high = _sparse_table(y, np.minimum), _sparse_table(y, np.maximum)
    t = steps[1:]
    created = y[t] > 0.0
    a = y[t].copy()
    death = np.full(N, -1, dtype=np.int64)
    death[t[created]] = t[created] + 1  # a rise's corner (x, x) goes at the next change
    # a fall's corner: A is the largest input since the last one below y[f] (a corner with b = y[f] is remade)
    fall = np.flatnonzero((y[t] < y[:-1]) & created) + 1
    level_y = y[fall]
    end = _reach_back(low, fall, lambda block: block >= level_y)
    span = fall - end  # at least 1: the input before a fall is above it
    level = np.floor(np.log2(span)).astype(np.int64)
    peak = np.empty(fall.size)
    for j in np.unique(level):
        at = level == j
        width = 1 << int(j)
        peak[at] = np.maximum(high[j][end[at]], high[j][fall[at] - width])
    a[fall - 1] = peak
    # ... and goes at the first later input <= y[f] or >= A
    pos = fall + 1
    for j in range(len(low) - 1, -1, -1):
        width = 1 << j
        ok = pos + width <= N
        idx = np.where(ok, pos, 0)
        inside = (low[j][idx] > level_y) & (high[j][idx] < peak)
        pos = np.where(ok & inside, pos + width, pos)
    death[fall] = pos
    # predecessor: the latest earlier corner still alive after step t
    latest = _sparse_table(death, np.maximum)
    end = _reach_back(latest, t, lambda block: block <= t)
    pred = end - 1
    corner_a = np.zeros(N)
    corner_a[t] = a
    below = np.where(pred >= 1, y[np.maximum(pred, 0)], 0.0)
    corner_bp = np.zeros(N)
    corner_bp[t] = below
    # events: a creation at its step, a death at its step; corners born and gone before the first input are none
    born = t[created]
    dies = death[born]
    real = dies >= virtual
    keep_birth = np.ones(born.size, dtype=bool) if virtual <= 1 else (born >= virtual) | real
    gone = dies < N
    ev_step = np.concatenate([born[keep_birth], dies[gone & real]])
    ev_corner = np.concatenate([born[keep_birth], born[gone & real]])
    ev_sign = np.concatenate([np.ones(int(keep_birth.sum())), -np.ones(int((gone & real).sum()))])
    order = np.lexsort((ev_corner, ev_step))
    ev_step, ev_corner, ev_sign = ev_step[order], ev_corner[order], ev_sign[order]
    m = ev_step.size
    out_sample = np.repeat(sample[ev_step], 2)
    out_sign = np.empty(2 * m)
    out_sign[0::2] = ev_sign
    out_sign[1::2] = -ev_sign
    out_x = np.repeat(corner_a[ev_corner], 2)
    out_y = np.empty(2 * m)
    out_y[0::2] = y[ev_corner]
    out_y[1::2] = corner_bp[ev_corner]
    alive = born[dies == N]
    curve._a[:], curve._b[:] = corner_a[alive].tolist(), y[alive].tolist()
    curve.position = float(y[-1])
    return out_sample, out_sign, out_x, out_y


def everett_at(levels: int, p: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``F(x_t, y_t)`` (um) for a prefix table ``p`` ``(n_cells,)`` at many points ``(T,)`` (grid
    coordinates, ``0 <= y <= x <= L``): :func:`everett_weights`'s combination evaluated directly (five
    lookups in the ``(L+1)^2`` table a point) rather than spelt out as sparse entries."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    top = levels - 1
    stride = levels + 1
    table = np.append(p, 0.0).take(_table_columns(levels).ravel())  # column -1 (F = 0) takes the appended 0
    i = np.minimum(np.floor(x), top).astype(np.int64)
    j = np.minimum(np.floor(y), top).astype(np.int64)
    fx = x - i
    fy = y - j
    at = i * stride + j
    low = table.take(at)
    low *= 1.0 - fy
    low += fy * table.take(at + 1)
    high = table.take(at + stride)
    high *= 1.0 - fy
    high += fy * table.take(at + stride + 1)
    high -= low
    high *= fx
    high += low  # (1 - fx) low + fx high: the bilinear part
    diagonal = (j + 1) * stride + j
    rise = table.take(diagonal + 1)
    rise -= table.take(diagonal)
    rise *= fy * (np.minimum(x - j, 1.0) - fy)  # the diagonal triangle's quadratic area
    high += rise
    return high


def everett_changes(grid: Grid, xs: np.ndarray, curve: MemoryCurve, p: np.ndarray) -> np.ndarray:
    """``E p`` of :func:`everett_increments` without forming ``E``: the change of ``Phi`` (um) at each
    input ``xs`` ``(n,)`` (grid coordinates) for the prefix table ``p`` ``(n_cells,)``; ``curve`` is the
    memory before the first input (moved through ``xs``).  For one product the replay's terms are summed
    directly -- about a third of the cost of assembling ``E`` -- equal to ``E @ p`` to rounding."""
    sample, sign, tx, ty = everett_terms(curve, xs)
    values = everett_at(grid.levels, p, tx, ty)
    values *= sign
    return np.bincount(sample, weights=values, minlength=len(xs)).astype(float, copy=False)  # int when empty


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
        (weight * sign.take(term), (sample.take(term), column)), shape=(n, grid.n_cells)
    )
