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
    everett_increments, prefix_sums, prefix_sums_adjoint, total_index,
)
from .grid import Grid
from .memory import InitialState
from .regressor import check_inputs, initial_curve, n_parameters


def _reverse_cumsum(r: np.ndarray) -> np.ndarray:
    return np.cumsum(r[::-1], axis=0)[::-1]


class RegressorOperator(LinearOperator):
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

    def _matvec(self, w: np.ndarray) -> np.ndarray:
        return self._matmat(np.asarray(w, dtype=float).reshape(-1, 1)).ravel()

    def _rmatmat(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        total = r.sum(axis=0)
        g = 2.0 * (self._increments_t @ _reverse_cumsum(r))
        g[self._total] -= total
        tail = [total[None]]
        if self.thermal_term:
            tail.append((self.inputs @ r)[None])
        return np.concatenate([prefix_sums_adjoint(self.grid, g), *tail])

    def _rmatvec(self, r: np.ndarray) -> np.ndarray:
        return self._rmatmat(np.asarray(r, dtype=float).reshape(-1, 1)).ravel()

    def _adjoint(self) -> LinearOperator:
        return LinearOperator(self.shape[::-1], matvec=self._rmatvec, rmatvec=self._matvec,
                              matmat=self._rmatmat, rmatmat=self._matmat, dtype=self.dtype)

    # -------------------------------------------------------------- views
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

        Built a block of rows at a time from the running Everett increments,
        ``O(len(rows) (P + L^2))`` time; only the requested rows are held.
        For small problems and the dense reference: the products above never
        need it.
        """
        n, P = self.shape
        c = self.grid.n_cells
        rows = np.arange(n)[rows if rows is not None else slice(None)]
        out = np.empty((rows.size, P))
        out[:, c] = 1.0
        if self.thermal_term:
            out[:, c + 1] = self.inputs[rows]
        if rows.size == 0:
            return out
        columns = self.increments.T  # (cells, n), column slices are cheap
        span = max(16, 4_000_000 // c)  # samples per block: about 32 MB of work arrays
        running = np.zeros(c)  # Phi (as prefix-table coefficients) before the block
        for lo in range(0, int(rows[-1]) + 1, span):
            hi = min(lo + span, int(rows[-1]) + 1)
            first, last = np.searchsorted(rows, [lo, hi])
            if first == last:
                running += columns[:, lo:hi].sum(axis=1)
                continue
            phi = np.cumsum(columns[:, lo:hi].toarray(), axis=1)
            phi += running[:, None]
            running = phi[:, -1].copy()
            # each row's Phi as a function of the cell weights: (cells, rows in block)
            weights = prefix_sums_adjoint(self.grid, phi[:, rows[first:last] - lo])
            out[first:last, :c] = weights.T
            out[first:last, :c] *= 2.0
            out[first:last, :c] -= 1.0
        return out
