"""'CS Order Non-negative' (equation 17).

``min_w ||Psi S_order w - q_order||_2^2`` with every cell weight >= 0, where
``q_order`` is the 'CS Order' solution.  ``Psi`` is orthonormal, so this is
``min ||S w - b_hat||_2`` with ``b_hat = Psi^{-1} q_order`` put back in
acquisition order: non-negative least squares on the reconstructed outputs.
``mu0`` and ``c_d`` are free.  ``S`` is square and invertible, so the
minimiser is unique: the dense reference runs scipy's NNLS on the dense
``S``, the fast path the same problem in output space with the sparse
``S^{-1}`` (:mod:`.output_space`).
"""

from __future__ import annotations

from .compressive import CompressiveSensingOrder
from .nnls import nnls_free
from .output_space import nnls_outputs
from .problem import Problem


class CompressiveSensingOrderNonNegative(CompressiveSensingOrder):
    name = "cs_order_nn"
    label = "CS Order Non-negative"

    def _solve(self, problem: Problem):
        b_hat, info_cs = self.reconstruct_sorted(problem)
        if self.dense:
            w, info = nnls_free(problem.regressor, b_hat, problem.n_cells)
        else:
            w, info = nnls_outputs(problem.sparse_inverse, problem.n_cells, b_hat)
        return w, {**info, "cs_order": info_cs}
