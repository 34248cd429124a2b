"""'Least Squares': constrained least squares on the measured rows (section 2.3).

``min ||A S w - y_b||_2`` with every cell weight >= 0 and ``mu0``, ``c_d``
free -- Matlab's ``lsqnonneg`` as used by the paper.  Works on any input
history (the design need not be square).

With fewer measurements than parameters the minimiser is not unique and
the answer is the one Lawson-Hanson's pivoting picks (:mod:`.nnls`), so
both solvers run Lawson-Hanson: ``"dense"`` on the measured rows of the
dense ``S``, ``"fast"`` through the matrix-free operator
(:func:`.nnls.nnls_operator`), which never forms ``S``: on the ``P x P``
factor of the Gram matrix when there are more measured rows than
parameters, else on the measured rows (small) or the operator (large).
"""

from __future__ import annotations

from . import nnls
from .base import Method
from .nnls import nnls_free, nnls_operator
from .problem import Problem


class LeastSquares(Method):
    name = "ls"
    label = "Least Squares"
    refits_live = True

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        """Measured at L = 60-1000 on 467 rows, L = 100/200 on the damped oscillation, L = 20-60 on the FORC
        file (42,000 of 84,000 rows; the Gram factor's paths, 2026-11-28)."""
        p, m = parameters, measured
        if m > p and p * p <= nnls.GRAM_LH_ENTRIES:
            # tall: the Gram matrix from the sparse memory states (the rows, then the prefix sums' adjoint on
            # P x P), its factor (an eigendecomposition when A S is rank-deficient), Lawson-Hanson on it
            return 2e-6 * m + 1e-7 * p * p + 7e-10 * p ** 3, 56.0 * p * p + 250.0 * m
        if min(m, p) * p <= nnls.DENSE_LH_ENTRIES:  # scipy's NNLS on dense rows
            return 2e-9 * m * p * min(m, p), 24.0 * min(m, p) * p
        # Lawson-Hanson on operator products: one product per step, a thin QR of the passive columns
        return 1e-7 * m * p + 3e-10 * m * min(m, p) ** 2, 8.0 * (m * min(m, p, 2000) + 4 * p)

    def _solve(self, problem: Problem):
        problem.require_thermal_identifiable(self.name)
        if self.dense:
            return nnls_free(problem.measured_regressor, problem.measured, problem.n_nonneg)
        return nnls_operator(problem.operator, problem.rows, problem.measured, problem.n_nonneg)
