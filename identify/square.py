"""The square damped-oscillation design: ``S^{-1}`` without the dense matrix.

Proposition 1 of the paper: under the damped oscillation (plus, with the
thermal term, our thermal point) ``S`` is square and invertible.  Two
structured ways to use that, both ``O(n)`` to ``O(n L)``:

* :class:`SquareSolver` factorises the differenced system.  Differencing
  consecutive rows (``D``, the inverse of the cumulative sum ``C``) turns
  ``S = C [2 E' Pi, 1, v]`` (:mod:`identify.operators`) into
  ``D S = [2 E' Pi, e_0, D v]``, and in the prefix-table basis
  ``K = [2 E', e_0, D v]`` is sparse: each step of the damped oscillation
  moves the input by one wall, changes one corner of the memory curve and
  brings in one new table entry (the triangular structure behind the
  paper's proof).  SuperLU factorises ``K`` with almost no fill-in, and
  ``S^{-1} b = Pi^{-1} K^{-1} D b`` is a sparse solve plus a four-point
  difference.

* :func:`sparse_inverse` builds ``T = S^{-1}`` itself, which is sparse: at
  most four outputs per cell weight (six with the thermal term).  On the
  walls a step of the input switches one *segment* of cells (part of an
  alpha row when rising, of a beta column when falling), and
  ``b_n - b_{n-1} = 2 sigma sum_{segment} mu + c_d (v_n - v_{n-1})``.  A
  cell at the end of a segment is the difference of two steps whose
  segments differ by that cell alone; a segment of one cell gives the cell
  directly.  The few cells found neither way, ``mu0`` and ``c_d`` come from
  transposed solves, and the result is checked against ``S`` before use.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from .errors import IdentifyError
from .everett import density_from_prefix, total_index
from .grid import Grid
from .operators import RegressorOperator

#: Relative accuracy ``||T S x - x||`` that :func:`sparse_inverse` must reach per row.
INVERSE_CHECK = 1e-9


class SquareSolver:
    """``S^{-1} b`` and ``S^{-T} r`` for a square invertible ``S`` given as an operator.

    Factorises the sparse differenced system once (SuperLU); each solve is
    then ``O(n)`` plus a four-point difference.  Raises
    :class:`IdentifyError` when the matrix is singular.
    """

    def __init__(self, operator: RegressorOperator) -> None:
        n, P = operator.shape
        if n != P:
            raise IdentifyError(f"the square solve needs a square S, got {n} x {P}")
        self.operator = operator
        grid = operator.grid
        # 2 E' with E' = E - e_0 (sum of weights)/2: the -sum(mu) of every row, differenced
        total = scipy.sparse.csc_array(([-1.0], ([0], [total_index(grid)])), shape=(n, grid.n_cells))
        cols = [2.0 * operator.increments.tocsc() + total, scipy.sparse.csc_array(np.eye(n, 1))]
        if operator.thermal_term:
            cols.append(scipy.sparse.csc_array(np.diff(operator.inputs, prepend=0.0)[:, None]))
        self.matrix = scipy.sparse.hstack(cols, format="csc")
        try:
            self._lu = scipy.sparse.linalg.splu(self.matrix)
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise IdentifyError(f"S is singular: {exc}") from None

    @property
    def grid(self) -> Grid:
        return self.operator.grid

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``w = S^{-1} b`` for ``b`` of shape ``(n,)`` or ``(n, k)``."""
        b = np.asarray(b, dtype=float)
        db = np.diff(b, axis=0, prepend=np.zeros((1,) + b.shape[1:]))
        z = self._lu.solve(db)
        c = self.grid.n_cells
        return np.concatenate([density_from_prefix(self.grid, z[:c]), z[c:]])

    def solve_transpose(self, r: np.ndarray) -> np.ndarray:
        """``S^{-T} r`` for ``r`` of shape ``(n,)`` or ``(n, k)``."""
        r = np.asarray(r, dtype=float)
        c = self.grid.n_cells
        # S^{-T} = D^T K^{-T} Pi^{-T}
        g = np.concatenate([_prefix_adjoint_inverse(self.grid, r[:c]), r[c:]])
        y = self._lu.solve(g, trans="T")
        return y - np.concatenate([y[1:], np.zeros((1,) + y.shape[1:])])

    @cached_property
    def inverse(self) -> scipy.sparse.csr_array:
        """The explicit sparse ``S^{-1}``, shape ``(P, n)`` (see :func:`sparse_inverse`)."""
        return sparse_inverse(self)

    def reciprocal_condition(self) -> tuple[float, np.ndarray]:
        """``1 / (||S||_1 ||S^{-1}||_1)`` estimated from a few solves, and where ``S^{-1}`` is largest.

        What LAPACK's ``dgecon`` does for a dense LU, without the dense
        matrix.  ``||S||_1`` is exact: every signed area is in ``[-1, 1]``
        and the bias column is all ones, so the largest column sum is ``n``,
        or ``||v||_1`` (V) when the thermal column's is larger.
        ``||S^{-1}||_1`` is Hager's estimate (scipy's ``onenormest`` with one
        column: deterministic, about five solves with ``S`` and ``S^T``), a
        lower bound, so the result is never below the true reciprocal
        condition number (in our tests at most twice it, as ``dgecon``'s).
        The vector returned, ``(P,)``, is the column of ``S^{-1}`` that
        attains the estimate: when ``S`` is nearly singular it points along
        the parameters that ``S`` cannot tell apart.
        """
        n = self.operator.shape[0]
        norm = float(n)
        if self.operator.thermal_term:
            norm = max(norm, float(np.abs(self.operator.inputs).sum()))
        inverse = scipy.sparse.linalg.LinearOperator(
            (n, n), matvec=self.solve, rmatvec=self.solve_transpose,
            matmat=self.solve, rmatmat=self.solve_transpose, dtype=float,
        )
        with np.errstate(all="ignore"):
            estimate, _, column = scipy.sparse.linalg.onenormest(inverse, t=1, compute_v=True, compute_w=True)
        if not np.isfinite(estimate) or estimate <= 0:
            return 0.0, np.asarray(column, dtype=float)
        return 1.0 / (norm * float(estimate)), np.asarray(column, dtype=float)


def _prefix_adjoint_inverse(grid: Grid, g: np.ndarray) -> np.ndarray:
    """``x`` with ``prefix_sums_adjoint(grid, x) = g`` (mirrored four-point differences)."""
    L = grid.levels
    table = np.zeros((L + 1, L + 1) + g.shape[1:])
    table[grid.cell_alpha, grid.cell_beta] = g
    # right of the diagonal the suffix sums repeat the next diagonal entry
    d = np.arange(L)
    table[d, d + 1] = table[d + 1, d + 1]
    i, j = grid.cell_alpha, grid.cell_beta
    return table[i, j] - table[i + 1, j] - table[i, j + 1] + table[i + 1, j + 1]


# ------------------------------------------------------------------ sparse inverse
def _wall_segments(operator: RegressorOperator) -> dict[tuple[int, int, int, int], tuple[int, float]]:
    """Segments switched by the one-wall steps: ``(kind, band, lo, hi) -> (step n, sign)``.

    ``kind`` 0: cells ``(band, j)`` for ``lo <= j <= hi`` switched up (the
    input rose through alpha band ``band``); ``kind`` 1: cells ``(i, band)``
    for ``lo <= i <= hi`` switched down (it fell through beta band ``band``).
    """
    curve = operator.start.copy()
    xs = operator.grid.coordinates(operator.inputs).tolist()
    segments: dict[tuple[int, int, int, int], tuple[int, float]] = {}
    for n, x in enumerate(xs):
        p = curve.position
        if n and x == int(x) and p == int(p) and abs(x - p) == 1:
            if x > p:  # hysterons (p, j) with j from plus_below to p switch up
                key = (0, int(p), int(curve.plus_below(p + 0.5)), int(p))
                sign = 1.0
            else:  # hysterons (i, x) with i from x to plus_left - 1 switch down
                key = (1, int(x), int(x), int(curve.plus_left(x + 0.5)) - 1)
                sign = -1.0
            if key[2] <= key[3]:
                segments.setdefault(key, (n, sign))
        curve.apply(x)
    return segments


def _segment_rows(grid: Grid, segments: dict) -> dict[int, list[tuple[int, float]]]:
    """Cell -> its weight as a combination of output steps (without the thermal term)."""
    rows: dict[int, list[tuple[int, float]]] = {}

    def cell(kind: int, band: int, k: int) -> int:
        return grid.cell_index(band, k) if kind == 0 else grid.cell_index(k, band)

    for (kind, band, lo, hi), (n, s) in segments.items():
        step = [(n, s / 2), (n - 1, -s / 2)]  # sum over the segment of mu = s (b_n - b_{n-1}) / 2
        if lo == hi:
            rows.setdefault(cell(kind, band, lo), step)
            continue
        for k, shorter in ((lo, (kind, band, lo + 1, hi)), (hi, (kind, band, lo, hi - 1))):
            if shorter in segments:
                m, t = segments[shorter]
                rows.setdefault(cell(kind, band, k), step + [(m, -t / 2), (m - 1, t / 2)])
    return rows


def sparse_inverse(solver: SquareSolver) -> scipy.sparse.csr_array:
    """The explicit ``T = S^{-1}`` (``P x n``, about ``4 n`` non-zeros) of a square design.

    Rows come from pairs of wall steps (see the module docstring); rows not
    found that way, and ``mu0`` and ``c_d``, from transposed solves.  Every
    row is checked: ``T S x = x`` to :data:`INVERSE_CHECK` for two random
    ``x``; rows that fail are recomputed by transposed solves.
    """
    op = solver.operator
    grid = op.grid
    n, P = op.shape
    c = grid.n_cells
    rows = _segment_rows(grid, _wall_segments(op))
    solved = np.setdiff1d(np.arange(P), np.fromiter(rows, dtype=np.int64, count=len(rows)))
    dense = _transposed_rows(solver, solved)
    counts = np.fromiter((len(t) for t in rows.values()), dtype=np.int64, count=len(rows))
    flat = np.array([term for terms in rows.values() for term in terms]).reshape(-1, 2)
    r_idx = [np.repeat(np.fromiter(rows, dtype=np.int64, count=len(rows)), counts)]
    c_idx = [flat[:, 0].astype(np.int64)]
    vals = [flat[:, 1]]
    if op.thermal_term and rows:  # remove the c_d these steps carry: T_k -= (T_k . v) T_cd
        cd_row = dense[solved.searchsorted(c + 1)]
        cd_cols = np.flatnonzero(cd_row)
        carried = np.bincount(
            np.repeat(np.arange(len(rows)), counts), vals[0] * op.inputs[c_idx[0]], minlength=len(rows)
        )
        r_idx.append(np.repeat(r_idx[0][np.cumsum(counts) - 1], cd_cols.size))
        c_idx.append(np.tile(cd_cols, len(rows)))
        vals.append(-np.outer(carried, cd_row[cd_cols]).ravel())
    nz_r, nz_c = np.nonzero(dense)
    r_idx.append(solved[nz_r])
    c_idx.append(nz_c)
    vals.append(dense[nz_r, nz_c])
    inverse = _assemble(r_idx, c_idx, vals, (P, n))
    bad = _failed_rows(inverse, op)
    if bad.size:
        keep = np.ones(P, dtype=bool)
        keep[bad] = False
        inverse = scipy.sparse.csr_array(scipy.sparse.diags_array(keep.astype(float)) @ inverse)
        fixed = _transposed_rows(solver, bad)
        nz_r, nz_c = np.nonzero(fixed)
        inverse = inverse + scipy.sparse.csr_array((fixed[nz_r, nz_c], (bad[nz_r], nz_c)), shape=(P, n))
        if _failed_rows(inverse, op).size:  # pragma: no cover - S numerically singular
            raise IdentifyError("S is too ill-conditioned for its sparse inverse")
    return scipy.sparse.csr_array(inverse)


def _assemble(r_idx, c_idx, vals, shape) -> scipy.sparse.csr_array:
    if not r_idx:
        return scipy.sparse.csr_array(shape)
    a = scipy.sparse.csr_array(
        (np.concatenate(vals), (np.concatenate(r_idx), np.concatenate(c_idx))), shape=shape
    )
    a.sum_duplicates()
    a.eliminate_zeros()
    return a


def _transposed_rows(solver: SquareSolver, which: np.ndarray, block: int = 256) -> np.ndarray:
    """Rows ``which`` of ``S^{-1}``, dense ``(len(which), n)``, entries below rounding set to 0."""
    n = solver.operator.shape[0]
    out = np.zeros((which.size, n))
    for start in range(0, which.size, block):
        part = which[start : start + block]
        e = np.zeros((n, part.size))
        e[part, np.arange(part.size)] = 1.0
        rows = solver.solve_transpose(e).T
        scale = np.abs(rows).max(axis=1, keepdims=True)
        rows[np.abs(rows) <= 1e-12 * scale] = 0.0
        out[start : start + part.size] = rows
    return out


def _failed_rows(inverse: scipy.sparse.csr_array, op: RegressorOperator) -> np.ndarray:
    x = np.random.default_rng(0).normal(size=(op.shape[1], 2))
    err = np.abs(inverse @ op.matmat(x) - x).max(axis=1)
    return np.flatnonzero(err > INVERSE_CHECK * (1.0 + np.abs(x).max(axis=1)))
