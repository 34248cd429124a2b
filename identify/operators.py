"""The regressor ``S`` as a matrix-free operator.

``S`` (equation 22, :mod:`identify.regressor`) is never formed.  With the
prefix table ``p = Pi mu`` of the cell weights and the Everett increments
``E`` of the input sequence (:mod:`identify.everett`)::

    S w = 2 C E p - (sum mu) 1 + mu0 1 + c_d v,     C = cumulative sum

so ``S w`` and ``S^T r`` cost ``O(n + L^2)`` time and memory for any input
sequence: the 83,600-point FORC data of issue 9 at L = 40 or the
20,101-point damped oscillation at L = 200 take milliseconds, where the
dense ``S`` would take 3.2 GB.

The square damped-oscillation design is solved in :mod:`identify.square`.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse
from scipy.sparse.linalg import LinearOperator

from .everett import (
    _flat_cells, everett_increments, prefix_sums, prefix_sums_adjoint, total_index,
)
from .grid import Grid
from .memory import InitialState
from .regressor import check_inputs, initial_curve, n_parameters


#: A running sum of ``E``'s column within this many times its largest increment is a cancelled term (zero):
#: the rounding of a sum of a few thousand increments is far below it, a genuine state entry far above.
STATE_ZERO = 1e-11


def _reverse_cumsum(r: np.ndarray) -> np.ndarray:
    return np.cumsum(r[::-1], axis=0)[::-1]


class _MatmatOperator(LinearOperator):
    """The plumbing every operator here shares: vector products, the adjoint and row views, all through
    the subclass's ``_matmat`` / ``_rmatmat`` (products with blocks of columns)."""

    def _matvec(self, w: np.ndarray) -> np.ndarray:
        return self._matmat(np.asarray(w, dtype=float).reshape(-1, 1)).ravel()

    def _rmatvec(self, r: np.ndarray) -> np.ndarray:
        return self._rmatmat(np.asarray(r, dtype=float).reshape(-1, 1)).ravel()

    def _adjoint(self) -> LinearOperator:
        return LinearOperator(self.shape[::-1], matvec=self._rmatvec, rmatvec=self._matvec,
                              matmat=self._rmatmat, rmatmat=self._matmat, dtype=self.dtype)

    def gram(self, rows: np.ndarray) -> np.ndarray:
        """``(A S)^T (A S)`` for the sorted measured rows ``rows`` ``(M,)``: ``(P, P)``, without ``A S``.

        The cells' block is the base regressor's :meth:`RegressorOperator.cell_gram` (the memory states
        at the measured rows are sparse); the few other columns (``mu0``, ``c_d``, an effect's terms, the
        penalty rows) by one product each way.  ``O(n + M s^2 + L^4)`` for ``s`` non-zeros per state,
        where the block products took ``O(n P)``.
        """
        rows = np.asarray(rows, dtype=np.int64)
        n_rows, P = self.shape
        cells, base, scale = self._cell_part()
        data = rows[rows < base.shape[0]]
        weights = None if scale is None else scale[data] ** 2
        out = np.empty((P, P))
        out[np.ix_(cells, cells)] = base.cell_gram(data, weights)
        other = np.setdiff1d(np.arange(P), cells)
        if other.size:
            unit = np.zeros((P, other.size))
            unit[other, np.arange(other.size)] = 1.0
            mask = np.zeros(n_rows)
            mask[rows] = 1.0
            block = self._rmatmat(self._matmat(unit) * mask[:, None])
            out[:, other] = block
            out[other, :] = block.T
        return out

    def _cell_part(self) -> tuple[np.ndarray, "RegressorOperator", np.ndarray | None]:
        """Where the cells sit in ``w``, the :class:`RegressorOperator` they belong to, and the rows'
        scale (``None``: 1)."""
        raise NotImplementedError

    def rows(self, rows: np.ndarray) -> LinearOperator:
        """``A S``: the operator restricted to the rows ``rows``, shape ``(M, P)``."""
        rows = np.asarray(rows, dtype=np.int64)
        n = self.shape[0]

        def matmat(w):
            return self._matmat(np.asarray(w, dtype=float).reshape(self.shape[1], -1))[rows]

        def rmatmat(r):
            r = np.asarray(r, dtype=float).reshape(rows.size, -1)
            full = np.zeros((n, r.shape[1]))
            full[rows] = r
            return self._rmatmat(full)

        return LinearOperator(
            (rows.size, self.shape[1]),
            matvec=lambda w: matmat(w).ravel(), rmatvec=lambda r: rmatmat(r).ravel(),
            matmat=matmat, rmatmat=rmatmat, dtype=self.dtype,
        )


class RegressorOperator(_MatmatOperator):
    """``S`` for the input sequence ``inputs`` (V), shape ``(n, P)``, without forming it.

    ``matvec(w)`` is ``S w`` (um) for ``w = (mu, mu0[, c_d])``; ``rmatvec(r)``
    is ``S^T r``.  Both cost ``O(n + L^2)``; building the operator replays
    the memory curve once (``O(n)`` amortised).  Memory use is ``O(n + L^2)``.
    """

    def __init__(
        self,
        grid: Grid,
        inputs: np.ndarray,
        thermal_term: bool,
        initial: InitialState = "negative",
        history: np.ndarray | None = None,
    ) -> None:
        v = check_inputs(inputs)
        self.grid = grid
        self.inputs = v
        self.thermal_term = bool(thermal_term)
        curve = initial_curve(grid, initial, history)
        #: The memory curve before the first input (grid coordinates).
        self.start = curve.copy()
        self.increments = everett_increments(grid, grid.coordinates(v), curve)
        self._total = total_index(grid)
        super().__init__(np.float64, (v.size, n_parameters(grid, thermal_term)))

    @cached_property
    def _increments_t(self) -> scipy.sparse.csr_array:
        return self.increments.T.tocsr()

    # -------------------------------------------------------------- products
    def _matmat(self, w: np.ndarray) -> np.ndarray:
        w = np.asarray(w, dtype=float)
        c = self.grid.n_cells
        p = prefix_sums(self.grid, w[:c])
        out = np.cumsum(self.increments @ p, axis=0)
        out *= 2.0
        out += w[c] - p[self._total]
        if self.thermal_term:
            out += self.inputs[:, None] * w[c + 1]
        return out

    def _rmatmat(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        total = r.sum(axis=0)
        g = 2.0 * (self._increments_t @ _reverse_cumsum(r))
        g[self._total] -= total
        tail = [total[None]]
        if self.thermal_term:
            tail.append((self.inputs @ r)[None])
        return np.concatenate([prefix_sums_adjoint(self.grid, g), *tail])

    # -------------------------------------------------------------- Gram matrix
    def _cell_part(self) -> tuple[np.ndarray, "RegressorOperator", np.ndarray | None]:
        return np.arange(self.grid.n_cells), self, None

    def states(self, rows: np.ndarray) -> scipy.sparse.csr_array:
        """``Phi`` at the sorted rows ``rows`` ``(M,)``: ``(M, n_cells)`` on the prefix table, sparse.

        Row ``m`` is ``sum_{t <= rows[m]} E[t]`` -- the memory state there, a few terms per corner
        of the memory curve -- accumulated column by column over ``E``'s non-zeros (``O(nnz(E))``).
        A running sum within :data:`STATE_ZERO` of the column's largest increment is a term that
        was removed (the rounding of its cancellation) and is left out.
        """
        rows = np.asarray(rows, dtype=np.int64)
        n, c = self.increments.shape
        e = self._increments_csc
        if e.nnz == 0:
            return scipy.sparse.csr_array((rows.size, c))
        ptr = e.indptr
        value = np.empty(e.nnz)
        for j in np.flatnonzero(ptr[1:] > ptr[:-1]):  # a running sum down each column, column by column
            np.cumsum(e.data[ptr[j]:ptr[j + 1]], out=value[ptr[j]:ptr[j + 1]])
        column = np.repeat(np.arange(c), np.diff(ptr))
        largest = np.zeros(c)
        np.maximum.at(largest, column, np.abs(e.data))
        # an increment's value holds from its row to the column's next increment: the measured rows between
        first = np.searchsorted(rows, e.indices)
        last = np.empty_like(first)
        last[:-1] = first[1:]
        last[ptr[1:][ptr[1:] > ptr[:-1]] - 1] = rows.size
        keep = (last > first) & (np.abs(value) > STATE_ZERO * largest[column])
        starts, counts = first[keep], (last - first)[keep]
        total = int(counts.sum())
        offsets = np.repeat(np.cumsum(counts) - counts, counts)
        row = np.repeat(starts, counts) + (np.arange(total) - offsets)
        return scipy.sparse.csr_array((np.repeat(value[keep], counts), (row, np.repeat(column[keep], counts))),
                                      shape=(rows.size, c))

    def cell_gram(self, rows: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """The cells' block of ``(A S)^T W (A S)``, ``(n_cells, n_cells)``, for the sorted rows ``rows``
        and row weights ``W = diag(weights)`` (default 1).

        The cells' part of row ``t`` of ``S`` is ``(2 Phi_t - e_total) Pi`` (``Pi``: the prefix sums), so
        the block is ``Pi^T (4 Phi^T W Phi - 2 (s e^T + e s^T) + (sum W) e e^T) Pi`` with ``s = Phi^T W 1``:
        a sparse product over the few non-zeros of each state (:meth:`states`), then the prefix sums'
        adjoint on both sides (``O(L^4)``).
        """
        rows = np.asarray(rows, dtype=np.int64)
        phi = self.states(rows)
        w = np.ones(rows.size) if weights is None else np.asarray(weights, dtype=float)
        weighted = scipy.sparse.csr_array(phi.multiply(w[:, None]))
        inner = (phi.T @ weighted).toarray() * 4.0
        s = np.asarray(weighted.sum(axis=0)).ravel()
        t = self._total
        inner[t, :] -= 2.0 * s
        inner[:, t] -= 2.0 * s
        inner[t, t] += float(w.sum())
        half = prefix_sums_adjoint(self.grid, inner)
        return prefix_sums_adjoint(self.grid, np.ascontiguousarray(half.T)).T

    @cached_property
    def _increments_csc(self) -> scipy.sparse.csc_array:
        e = scipy.sparse.csc_array(self.increments)
        e.sum_duplicates()
        e.sort_indices()
        return e

    # -------------------------------------------------------------- views
    def column_norms(self) -> np.ndarray:
        """Euclidean norm of every column of ``S``, ``(P,)``, without forming ``S``.

        Uses ``S e_c`` one block of cells at a time (``O(n L^2)`` work in
        total, ``O(n L)`` memory).
        """
        P = self.shape[1]
        out = np.empty(P)
        block = max(1, int(4_000_000 // max(self.shape[0], 1)))
        for start in range(0, P, block):
            stop = min(P, start + block)
            e = np.zeros((P, stop - start))
            e[np.arange(start, stop), np.arange(stop - start)] = 1.0
            out[start:stop] = np.linalg.norm(self._matmat(e), axis=0)
        return out

    def dense_rows(self, rows: np.ndarray | slice | None = None) -> np.ndarray:
        """Rows ``rows`` (sorted) of the dense ``S``, all by default: ``(len(rows), P)``.

        ``Phi`` at each requested row is the running sum of the Everett
        increments up to it: the increments between consecutive requested
        rows are summed sparsely (one sparse product), laid out on the
        ``L x L`` prefix table and accumulated down the rows; the suffix
        sums over the table (:func:`~identify.everett.prefix_sums_adjoint`)
        then turn them into cell coefficients.  ``O(len(rows) L^2)`` time,
        a block of rows at a time (about 32 MB of work arrays); only the
        requested rows are held.  For small problems and the dense
        reference: the products above never need it.
        """
        n, P = self.shape
        c = self.grid.n_cells
        L = self.grid.levels
        rows = np.arange(n)[rows if rows is not None else slice(None)]
        out = np.empty((rows.size, P))
        out[:, c] = 1.0
        if self.thermal_term:
            out[:, c + 1] = self.inputs[rows]
        if rows.size == 0:
            return out
        last = int(rows[-1]) + 1
        # sample t contributes to every requested row from the first one at or after t on
        first_row = np.searchsorted(rows, np.arange(last))
        between = scipy.sparse.csr_array(
            (np.ones(last), (first_row, np.arange(last))), shape=(rows.size, last)
        ) @ self._table_increments[:last]
        cells = _flat_cells(L)
        running = np.zeros(L * L)
        block = max(1, 4_000_000 // (L * L))
        for lo in range(0, rows.size, block):
            hi = min(lo + block, rows.size)
            phi = between[lo:hi].toarray()
            phi[0] += running
            for i in range(1, hi - lo):
                phi[i] += phi[i - 1]
            running = phi[-1].copy()
            table = phi.reshape(hi - lo, L, L)
            for i in range(L - 2, -1, -1):  # suffix sums over the alpha bands, then the beta bands
                table[:, i, :] += table[:, i + 1, :]
            for j in range(L - 2, -1, -1):
                table[:, :, j] += table[:, :, j + 1]
            np.multiply(phi[:, cells], 2.0, out=out[lo:hi, :c])
            out[lo:hi, :c] -= 1.0
        return out

    @cached_property
    def _table_increments(self) -> scipy.sparse.csr_array:
        """``E`` with its columns on the flat ``L x L`` prefix table (``i L + j``): ``(n, L^2)``."""
        e = self.increments
        L = self.grid.levels
        return scipy.sparse.csr_array((e.data, _flat_cells(L)[e.indices], e.indptr), shape=(e.shape[0], L * L))


class AugmentedOperator(_MatmatOperator):
    """``[S, C]``: the regressor ``S`` with extra dense columns ``C`` (an effect's terms), shape ``(n, P + k)``.

    The parameter vector is ordered so that every sign-constrained entry
    comes first, as the non-negative solvers expect::

        w = (cells (n_cells), C's first ``k_nonneg`` coefficients (>= 0), mu0[, c_d], C's other coefficients)

    ``extra`` is ``(n, k)`` (output units per unit coefficient); products
    cost those of ``S`` plus ``O(n k)``.  :attr:`base_index` and
    :attr:`extra_index` map the parts of ``w`` back.

    ``penalty`` ``(r, k)`` (or None) appends ``r`` rows that act on the extra
    coefficients alone (zero on the density, ``mu0`` and ``c_d``): fitted to
    zero, they add ``||penalty beta||^2`` to a least-squares objective -- a
    roughness penalty that any of the solvers then honours.  The operator is
    ``(n + r, P + k)``; :attr:`inputs` still has the ``n`` applied inputs.
    """

    def __init__(self, base: RegressorOperator, extra: np.ndarray, k_nonneg: int = 0,
                 penalty: np.ndarray | None = None) -> None:
        extra = np.asarray(extra, dtype=float)
        if extra.ndim != 2 or extra.shape[0] != base.shape[0]:
            raise ValueError(f"extra columns must be ({base.shape[0]}, k), got {extra.shape}")
        if not 0 <= k_nonneg <= extra.shape[1]:
            raise ValueError(f"k_nonneg={k_nonneg} outside 0..{extra.shape[1]}")
        penalty = np.zeros((0, extra.shape[1])) if penalty is None else np.asarray(penalty, dtype=float)
        if penalty.ndim != 2 or penalty.shape[1] != extra.shape[1]:
            raise ValueError(f"penalty rows must be (r, {extra.shape[1]}), got {penalty.shape}")
        self.base = base
        self.extra = extra
        self.penalty = penalty
        self.n_inputs = base.shape[0]
        self.k_nonneg = int(k_nonneg)
        self.grid = base.grid
        self.inputs = base.inputs
        c, pb, k = base.grid.n_cells, base.shape[1], extra.shape[1]
        order = np.concatenate([np.arange(c), pb + np.arange(self.k_nonneg), np.arange(c, pb),
                                pb + np.arange(self.k_nonneg, k)])
        #: Position in ``w`` of each column of ``[S, C]``: ``w[position[j]]`` multiplies column ``j``.
        self.position = np.empty(pb + k, dtype=np.int64)
        self.position[order] = np.arange(pb + k)
        self.base_index = self.position[:pb]
        self.extra_index = self.position[pb:]
        super().__init__(np.float64, (base.shape[0] + penalty.shape[0], pb + k))

    def _matmat(self, w: np.ndarray) -> np.ndarray:
        w = np.asarray(w, dtype=float)
        we = w[self.extra_index]
        top = self.base._matmat(w[self.base_index]) + self.extra @ we
        if not self.penalty.shape[0]:
            return top
        return np.vstack([top, self.penalty @ we])

    def _rmatmat(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        n = self.n_inputs
        out = np.empty((self.shape[1], r.shape[1]))
        out[self.base_index] = self.base._rmatmat(r[:n])
        out[self.extra_index] = self.extra.T @ r[:n] + self.penalty.T @ r[n:]
        return out

    def _cell_part(self) -> tuple[np.ndarray, RegressorOperator, np.ndarray | None]:
        cells, base, scale = self.base._cell_part()
        return self.base_index[cells], base, scale

    def dense_rows(self, rows: np.ndarray | slice | None = None) -> np.ndarray:
        """Rows of the dense ``[S, C]`` (then the penalty rows) in the parameter order above, ``(len(rows), P + k)``."""
        picked = np.arange(self.shape[0])[rows if rows is not None else slice(None)]
        n = self.n_inputs
        data, pen = picked[picked < n], picked[picked >= n]
        out = np.zeros((picked.size, self.shape[1]))
        top = picked < n
        out[np.ix_(top, self.base_index)] = self.base.dense_rows(data)
        out[np.ix_(top, self.extra_index)] = self.extra[data]
        out[np.ix_(~top, self.extra_index)] = self.penalty[pen - n]
        return out

    def column_norms(self) -> np.ndarray:
        out = np.empty(self.shape[1])
        out[self.base_index] = self.base.column_norms()
        out[self.extra_index] = np.sqrt(np.sum(self.extra ** 2, axis=0) + np.sum(self.penalty ** 2, axis=0))
        return out


class RowScaledOperator(_MatmatOperator):
    """``diag(d) A``: every row of an operator ``A`` (a :class:`RegressorOperator` or
    :class:`AugmentedOperator`) multiplied by ``d`` ``(n,)``.

    A Gauss--Newton step through a sensor map ``y = g(u)`` needs it: the
    output's derivative with respect to the model's parameters is ``g'(u)``
    times the model's (:mod:`identify.effects.joint`).
    """

    def __init__(self, base: LinearOperator, scale: np.ndarray) -> None:
        scale = np.asarray(scale, dtype=float)
        if scale.shape != (base.shape[0],) or not np.all(np.isfinite(scale)):
            raise ValueError(f"row scale must be {base.shape[0]} finite numbers")
        self.base = base
        self.scale = scale
        self.grid = base.grid
        self.inputs = base.inputs
        self.n_inputs = getattr(base, "n_inputs", base.shape[0])
        for name in ("base_index", "extra_index", "position"):
            if hasattr(base, name):
                setattr(self, name, getattr(base, name))
        super().__init__(np.float64, base.shape)

    def _matmat(self, w: np.ndarray) -> np.ndarray:
        return self.scale[:, None] * self.base._matmat(np.asarray(w, dtype=float))

    def _rmatmat(self, r: np.ndarray) -> np.ndarray:
        return self.base._rmatmat(self.scale[:, None] * np.asarray(r, dtype=float))

    def _cell_part(self) -> tuple[np.ndarray, RegressorOperator, np.ndarray | None]:
        cells, base, scale = self.base._cell_part()
        return cells, base, self.scale if scale is None else self.scale * scale

    def dense_rows(self, rows: np.ndarray | slice | None = None) -> np.ndarray:
        picked = np.arange(self.shape[0])[rows if rows is not None else slice(None)]
        return self.scale[picked, None] * self.base.dense_rows(picked)

    def column_norms(self) -> np.ndarray:
        return np.linalg.norm(self.dense_rows(), axis=0)
