"""The compressive-sensing methods of section 3.2.

'CS' (equations 12-15)::

    q* = argmin ||q||_1  s.t.  A Psi^{-1} q = y_b     (or ||.||_2 <= epsilon)
    w  = S^{-1} Psi^{-1} q*

'CS Order' (equation 16): the same on the outputs sorted by value, the order
of all N outputs being known: ``S_order = S[order]``, ``A`` picks the sorted
positions of the measured rows, and ``w = S_order^{-1} Psi^{-1} q*``.

'CS Without DCT' (figure 4a): ``min ||mu||_1 s.t. A S w = y_b`` directly on
the cell weights (``mu0`` and ``c_d`` unpenalised).

Solvers (setting ``solver``): ``"dense"`` is the reference -- cvxpy with
Clarabel on the dense ``A Psi^{-1}`` or ``A S`` (:mod:`.l1`) and a dense LU
of ``S``.  ``"fast"`` solves the l1 problems on the partial DCT with fast
transforms (:mod:`.basis_pursuit`) and ``S^{-1}`` with the sparse
factorisation (:mod:`identify.square`); ``A S`` of 'CS Without DCT' has no
orthonormal rows, so that one is solved in output space with the sparse
``S^{-1}`` (:mod:`.output_space`).
"""

from __future__ import annotations

import numpy as np

from ..dct import dct_matrix, idct
from .base import Method
from .basis_pursuit import basis_pursuit_dct
from .l1 import basis_pursuit
from .output_space import l1_outputs
from .problem import Problem


def square_design_cost(points: int, measured: int) -> tuple[float, float]:
    """Time (s) and memory (bytes) of the square-design methods: the sparse ``S^-1`` and, for ``M <= 1000``,
    basis pursuit's dense basis (measured at L = 30, 100, 200)."""
    n, m = points, measured
    return 2e-4 * n + 2e-9 * min(m, 1000) ** 3, 2e3 * n + 8.0 * min(m, 1000) ** 2


class _Compressive(Method):
    """Shared settings: ``epsilon`` (um), the noise-aware bound, or None."""

    needs_square = True

    def __init__(self, epsilon: float | None = None, solver: str = "fast") -> None:
        super().__init__(solver)
        self.epsilon = epsilon

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        return square_design_cost(points, measured)

    def _recover_outputs(self, problem: Problem, positions: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, dict]:
        """``Psi^{-1} q*`` from the measurements ``y`` at ``positions`` of the transformed vector."""
        if self.dense:
            psi_inv = dct_matrix(problem.n).T
            q, info = basis_pursuit(psi_inv[positions], y, self.epsilon)
            return psi_inv @ q, info
        q, info = basis_pursuit_dct(problem.n, positions, y, self.epsilon)
        return idct(q), info

    def _solve_square(self, problem: Problem, b_hat: np.ndarray) -> np.ndarray:
        return problem.solve_square(b_hat, solver="dense" if self.dense else "fast")


class CompressiveSensing(_Compressive):
    """'CS': sparse DCT coefficients of the outputs ``S w`` in acquisition order."""

    name = "cs"
    label = "CS"

    def _solve(self, problem: Problem):
        b_hat, info = self._recover_outputs(problem, problem.rows, problem.measured)
        return self._solve_square(problem, b_hat), info


class CompressiveSensingOrder(_Compressive):
    """'CS Order': sparse DCT coefficients of the outputs sorted by value."""

    name = "cs_order"
    label = "CS Order"
    needs_order = True

    def reconstruct_sorted(self, problem: Problem) -> tuple[np.ndarray, dict]:
        """All ``n`` outputs, reconstructed, in acquisition order."""
        order = problem.require_order(self.name)
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        # y_b in the paper is A b_order: put the measurements in sorted order
        positions = rank[problem.rows]
        sort = np.argsort(positions)
        b_order, info = self._recover_outputs(problem, positions[sort], problem.measured[sort])
        return b_order[rank], info

    def _solve(self, problem: Problem):
        b_hat, info = self.reconstruct_sorted(problem)
        return self._solve_square(problem, b_hat), info


class CompressiveSensingNoDCT(Method):
    """'CS Without DCT': l1 on the cell weights directly (not sparse; poor, as in the paper)."""

    name = "cs_nodct"
    label = "CS Without DCT"
    needs_square = True

    def __init__(self, epsilon: float | None = None, solver: str = "fast") -> None:
        super().__init__(solver)
        self.epsilon = epsilon

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        return square_design_cost(points, measured)

    def _solve(self, problem: Problem):
        if self.dense:
            free = problem.n_parameters - problem.n_cells
            return basis_pursuit(problem.measured_regressor, problem.measured, self.epsilon, free=free)
        return l1_outputs(
            problem.sparse_inverse, problem.n_cells, problem.rows, problem.measured, self.epsilon
        )
