"""Convex problems of the square design, solved in output space with the sparse ``S^{-1}``.

On the damped-oscillation design ``S`` is invertible and ``T = S^{-1}`` is
sparse (:func:`identify.square.sparse_inverse`, about four outputs per cell
weight), so every model is ``w = T b`` for the vector ``b = S w`` of its
outputs at the applied inputs.  Written in ``b`` the problems of 'CS Order
Non-negative' and 'CS Without DCT' have a sparse constraint matrix ``T``
with a handful of entries per row and are solved exactly in ``O(n)``
memory -- where the dense reference works with the dense ``S`` (3.2 GB at
L = 200) and a dense ``A S``.

* :func:`nnls_outputs`: equation (17), ``min ||S w - b_hat||_2`` with every
  cell weight ``>= 0``, is ``min ||b - b_hat||_2`` s.t. ``T_cells b >= 0``:
  the projection of ``b_hat`` onto a polyhedral cone.  A primal-dual
  active-set iteration starting from the cells ``S^{-1} b_hat`` makes
  negative solves it exactly, one sparse factorisation per round (10-20
  rounds on the benchmark problems); should it not settle, Clarabel's interior
  point runs and the same iteration finishes its result exactly.
* :func:`l1_outputs`: 'CS Without DCT', ``min ||mu||_1`` s.t. ``A S w = y``,
  is ``min ||T_cells b||_1`` over the unmeasured outputs ``b_B`` with the
  measured ones fixed, ``b_A = y`` (or ``||b_A - y||_2 <= epsilon``): a
  sparse linear (second-order cone) program.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from ..errors import IdentifyError

#: Interior-point tolerances (relative gap and feasibility).
TOLERANCE = 1e-9
#: SuperLU settings for the symmetric positive definite Gram matrices: a symmetric
#: (minimum degree on ``G + G^T``) ordering and diagonal pivots, several times faster
#: than the default column ordering with partial pivoting, and with less fill.
SPD_LU = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}
#: Below this order the Gram blocks are factorised without supernodes (SuperLU's panel size
#: and relaxation 1): a quarter faster at L = 30 (about 350 rows, ten non-zeros each),
#: where the supernode bookkeeping costs more than it saves.
SMALL_GRAM = 2000


def _run(P, q, A, b, nonneg: int, soc: int = 0) -> tuple[np.ndarray, np.ndarray, dict]:
    """Clarabel on ``min x^T P x / 2 + q^T x`` s.t. ``b - A x`` in ``nonneg`` half-lines, then a
    second-order cone of ``soc`` rows (none when 0): ``(x, z, info)``."""
    import clarabel  # here, not at import: the command's start-up need not pay for it

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_rel = settings.tol_gap_abs = settings.tol_feas = TOLERANCE
    cones = [clarabel.NonnegativeConeT(nonneg)] + ([clarabel.SecondOrderConeT(soc)] if soc else [])
    solution = clarabel.DefaultSolver(
        scipy.sparse.csc_matrix(P), q, scipy.sparse.csc_matrix(A), b, cones, settings
    ).solve()
    status = str(solution.status)
    if status not in ("Solved", "AlmostSolved"):
        raise IdentifyError(f"the sparse solver stopped: {status}")
    info = {"status": status.lower(), "iterations": int(solution.iterations)}
    return np.asarray(solution.x), np.asarray(solution.z), info


def nnls_outputs(inverse: scipy.sparse.csr_array, n_cells: int, target: np.ndarray) -> tuple[np.ndarray, dict]:
    """``argmin ||S w - target||_2`` with ``w[:n_cells] >= 0``, for square ``S = inverse^{-1}``.

    Parameters
    ----------
    inverse: ``(P, n)`` sparse ``T = S^{-1}`` (``P == n``).
    n_cells: how many leading entries of ``w`` (the cell weights) are ``>= 0``.
    target: ``(n,)`` outputs ``b_hat`` (um).

    Returns ``w`` ``(P,)`` and diagnostics (``residual_norm``, ``active``
    constraints, ``exact``: whether the exact finish was accepted).
    """
    target = np.asarray(target, dtype=float)
    n = target.size
    cells = scipy.sparse.csr_array(inverse[:n_cells])
    scale = float(np.max(np.abs(target))) or 1.0
    y = target / scale
    # primal-dual active set from the cells the unconstrained S^{-1} b_hat makes negative;
    # the interior point only when that does not settle
    b = _active_set_projection(cells, y, cells @ y < 0)
    info = {"status": "active set", "iterations": 0, "exact": b is not None}
    if b is None:
        x, z, info = _run(
            scipy.sparse.identity(n, format="csc"), -y, -cells, np.zeros(n_cells), n_cells,
        )
        b = _active_set_projection(cells, y, z > np.maximum(cells @ x, 0.0))
        info["exact"] = b is not None
        if b is None:
            b = x
    w = (inverse @ b) * scale
    info.update(
        residual_norm=float(np.linalg.norm(b - y)) * scale,
        active=int(np.sum(w[:n_cells] <= 0)),
    )
    w[:n_cells] = np.maximum(w[:n_cells], 0.0)
    return w, info


def _active_set_projection(cells, y, active: np.ndarray, max_rounds: int = 40) -> np.ndarray | None:
    """The exact projection of ``y`` onto ``{b : cells b >= 0}`` by primal-dual active sets.

    With the constraints ``active`` taken as equalities the projection is
    ``b = y + cells_A^T nu`` with ``G_AA nu = -(cells y)_A``, ``G = cells
    cells^T`` (formed once; each round factorises its ``A x A`` block,
    sparse); constraints with ``nu < 0`` leave the active set and violated
    ones enter, until the optimality conditions hold up to rounding.  None
    when that does not happen within ``max_rounds``.
    """
    active = active.copy()
    tol = 1e-10 * max(1.0, float(np.max(np.abs(y))))
    gram = _SymmetricBlocks(scipy.sparse.csr_array(cells @ cells.T))
    cells_t = scipy.sparse.csr_array(cells.T)
    cy = cells @ y
    nu = np.zeros(cy.size)
    for _ in range(max_rounds):
        idx = np.flatnonzero(active)
        nu[:] = 0.0
        if idx.size:
            block = _solve_gram(gram.block(active), -cy[idx])
            if block is None:  # dependent active rows
                return None
            nu[idx] = block
        b = y + cells_t @ nu
        leave = idx[nu[idx] < -tol]
        enter = np.flatnonzero(~active & (cells @ b < -tol))
        if leave.size == 0 and enter.size == 0:
            return b
        active[leave] = False
        active[enter] = True
    return None


class _SymmetricBlocks:
    """Principal blocks ``G_AA`` of a sparse symmetric matrix, as CSC, by masking its entries.

    ``scipy.sparse`` fancy indexing (``G[idx][:, idx]``, then a CSR to CSC
    conversion) costs more than the factorisation of the block at L = 30;
    here a block is one boolean mask over the stored entries.  The CSR
    arrays of a symmetric matrix are also its CSC arrays.
    """

    def __init__(self, gram: scipy.sparse.csr_array) -> None:
        gram = scipy.sparse.csr_array(gram)
        gram.sort_indices()
        self.n = gram.shape[0]
        self.rows = np.repeat(np.arange(self.n), np.diff(gram.indptr))
        self.cols = gram.indices.astype(np.int64)
        self.data = gram.data

    def block(self, active: np.ndarray) -> scipy.sparse.csc_matrix:
        """``G_AA`` for the boolean mask ``active`` ``(n,)``, rows and columns in index order."""
        keep = active[self.rows] & active[self.cols]
        renumber = np.cumsum(active) - 1
        k = int(renumber[-1]) + 1
        indptr = np.zeros(k + 1, dtype=np.int32)
        np.cumsum(np.bincount(renumber[self.rows[keep]], minlength=k), out=indptr[1:])
        return scipy.sparse.csc_matrix(
            (self.data[keep], renumber[self.cols[keep]].astype(np.int32), indptr), shape=(k, k)
        )


def _solve_gram(gram, rhs: np.ndarray) -> np.ndarray | None:
    """``gram^{-1} rhs`` by sparse LU (a CSC block of the Gram matrix of a few-entries-per-row ``T``)."""
    try:
        small = {"panel_size": 1, "relax": 1} if gram.shape[0] < SMALL_GRAM else {}
        return scipy.sparse.linalg.splu(gram, **SPD_LU, **small).solve(rhs)
    except RuntimeError:  # singular: dependent rows
        return None


def l1_outputs(
    inverse: scipy.sparse.csr_array,
    n_cells: int,
    rows: np.ndarray,
    measured: np.ndarray,
    epsilon: float | None = None,
) -> tuple[np.ndarray, dict]:
    """``argmin ||w[:n_cells]||_1`` s.t. ``(S w)[rows] = measured`` (or within ``epsilon``, um).

    ``S`` is square with sparse inverse ``inverse`` ``(P, n)``; the last
    ``P - n_cells`` parameters (``mu0``, ``c_d``) are not penalised.
    """
    measured = np.asarray(measured, dtype=float)
    n = inverse.shape[1]
    cells = scipy.sparse.csc_array(inverse[:n_cells])
    scale = float(np.max(np.abs(measured))) or 1.0
    y = measured / scale
    free = np.setdiff1d(np.arange(n), rows)
    eye = scipy.sparse.identity(n_cells, format="csc")
    if epsilon is None:
        if free.size == 0:  # every output measured: nothing to choose
            b = np.zeros(n)
            b[rows] = y
            return (inverse @ b) * scale, {"status": "determined", "iterations": 0}
        # variables (b_free, t): min sum t, -t <= T_A y + T_B b_free <= t
        fixed = cells[:, rows] @ y
        tb = cells[:, free]
        A = scipy.sparse.vstack([scipy.sparse.hstack([tb, -eye]), scipy.sparse.hstack([-tb, -eye])])
        x, _, info = _run(
            scipy.sparse.csc_array((free.size + n_cells,) * 2),
            np.concatenate([np.zeros(free.size), np.ones(n_cells)]),
            A, np.concatenate([-fixed, fixed]), 2 * n_cells,
        )
        b = np.zeros(n)
        b[rows] = y
        b[free] = x[: free.size]
    else:
        # variables (b, t): -t <= T b <= t and (eps, y - b_A) in the second-order cone
        pick = scipy.sparse.csc_array(
            (np.ones(rows.size), (np.arange(rows.size), rows)), shape=(rows.size, n)
        )
        zero = scipy.sparse.csc_array((rows.size, n_cells))
        A = scipy.sparse.vstack([
            scipy.sparse.hstack([cells, -eye]),
            scipy.sparse.hstack([-cells, -eye]),
            scipy.sparse.csc_array((1, n + n_cells)),
            scipy.sparse.hstack([pick, zero]),
        ])
        rhs = np.concatenate([np.zeros(2 * n_cells), [float(epsilon) / scale], y])
        x, _, info = _run(
            scipy.sparse.csc_array((n + n_cells,) * 2),
            np.concatenate([np.zeros(n), np.ones(n_cells)]),
            A, rhs, 2 * n_cells, soc=rows.size + 1,
        )
        b = x[:n]
    return (inverse @ b) * scale, info
