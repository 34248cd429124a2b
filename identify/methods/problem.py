"""An identification problem: the regressor, which rows were measured, and what.

The whole applied input sequence defines the regressor ``S`` (every row's
memory state depends on everything applied before it); only the rows in
``rows`` were measured (``A`` in equation (12) selects them).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg
from scipy.sparse.linalg import LinearOperator, aslinearoperator

from ..errors import IdentifyError, MethodNotApplicable
from ..excitation import damped_oscillation
from ..grid import Grid
from ..memory import InitialState
from ..regressor import check_inputs, n_parameters, regressor_matrix

#: Reciprocal condition number below which a square design counts as singular.
SINGULAR_RCOND = 1e-12


def choose_rows(n: int, m: int, seed: int | None, include: tuple[int, ...] = ()) -> np.ndarray:
    """``m`` of the ``n`` row indices, sorted: ``include`` plus the rest uniformly at random."""
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or not 1 <= m <= n:
        raise IdentifyError(f"number of measurements M={m} must be between 1 and N={n}")
    fixed = np.unique(np.asarray(include, dtype=np.int64))
    if fixed.size > m:
        raise IdentifyError(f"M={m} is fewer than the {fixed.size} rows that must be measured")
    rng = np.random.default_rng(seed)
    rest = np.setdiff1d(np.arange(n), fixed)
    return np.sort(np.concatenate([fixed, rng.choice(rest, size=m - fixed.size, replace=False)]))


@dataclass(frozen=True, eq=False)
class Problem:
    """What every method gets.

    Attributes
    ----------
    grid: the discretisation.
    inputs: ``(n,)`` the whole applied input sequence (V).
    regressor: ``(n, P)`` the matrix ``S`` (see :mod:`identify.regressor`).
    thermal_term: whether ``S`` has the ``c_d`` column.
    rows: ``(M,)`` sorted indices of the measured rows.
    measured: ``(M,)`` the outputs measured at ``rows`` (um).
    order: ``(n,)`` the permutation sorting all ``n`` outputs ascending,
        when all of them are known (needed by the ``cs_order`` methods), else
        ``None``.
    curves: ``(n,)`` the curve each applied row belongs to (-1: none), for
        inputs made of first-order reversal curves (needed by ``everett``),
        else ``None``.
    """

    grid: Grid
    inputs: np.ndarray
    regressor: np.ndarray
    thermal_term: bool
    rows: np.ndarray
    measured: np.ndarray
    order: np.ndarray | None = None
    curves: np.ndarray | None = None

    @classmethod
    def build(
        cls,
        grid: Grid,
        inputs: np.ndarray,
        outputs: np.ndarray,
        rows: np.ndarray | None = None,
        thermal_term: bool = True,
        initial: InitialState = "negative",
        history: np.ndarray | None = None,
        regressor: np.ndarray | None = None,
        curves: np.ndarray | None = None,
    ) -> "Problem":
        """A problem from the applied inputs (V) and the outputs (um) of every row.

        ``outputs`` may hold NaN at rows that were not measured; ``rows``
        defaults to every row with a finite output.  When every output is
        known, ``order`` is their ascending sort (the paper's assumption for
        'CS Order').  ``regressor`` may be passed when already computed.
        ``curves`` ``(n,)`` numbers the curve of every applied row (-1: none).
        """
        v = check_inputs(inputs)
        y = np.asarray(outputs, dtype=float)
        if y.shape != v.shape:
            raise IdentifyError(
                f"{v.size} inputs but {y.size} outputs: the lengths must match"
            )
        known = np.isfinite(y)
        if rows is None:
            rows = np.flatnonzero(known)
        rows = np.asarray(rows)
        if rows.ndim != 1 or (rows.size and not np.issubdtype(rows.dtype, np.integer)):
            raise IdentifyError("measured rows must be a 1-D list of row indices")
        rows = np.unique(rows.astype(np.int64))
        if rows.size == 0:
            raise IdentifyError("no measured rows")
        if rows[0] < 0 or rows[-1] >= v.size:
            raise IdentifyError(f"measured row index out of range 0..{v.size - 1}")
        if not np.all(known[rows]):
            bad = rows[~known[rows]][0]
            raise IdentifyError(f"output of measured row {bad} is not finite")
        if regressor is None:
            regressor = regressor_matrix(grid, v, thermal_term, initial, history)
        elif regressor.shape != (v.size, n_parameters(grid, thermal_term)):
            raise IdentifyError("regressor shape does not match the inputs and grid")
        if curves is not None:
            curves = np.asarray(curves)
            if curves.shape != v.shape or (curves.size and not np.issubdtype(curves.dtype, np.integer)):
                raise IdentifyError(f"curve index must be {v.size} whole numbers, one per input")
            curves = curves.astype(np.int64)
        order = np.argsort(y, kind="stable") if np.all(known) else None
        return cls(grid, v, regressor, thermal_term, rows, y[rows].copy(), order, curves)

    # ---------------------------------------------------------- dimensions
    @property
    def n(self) -> int:
        """Number of applied inputs (rows of ``S``)."""
        return self.inputs.size

    @property
    def n_measured(self) -> int:
        return self.rows.size

    @property
    def n_parameters(self) -> int:
        return n_parameters(self.grid, self.thermal_term)

    @property
    def n_cells(self) -> int:
        return self.grid.n_cells

    @cached_property
    def operator(self) -> LinearOperator:
        """``S`` as a linear operator (``matvec`` = ``S w``, ``rmatvec`` = ``S^T r``).

        Solvers that only need products should use this rather than the
        dense ``regressor``, so they scale to large L.
        """
        return aslinearoperator(self.regressor)

    @property
    def measured_regressor(self) -> np.ndarray:
        """``A S``: the rows of ``S`` that were measured, shape ``(M, P)``."""
        return self.regressor[self.rows]

    # ---------------------------------------------------------- square design
    @cached_property
    def square_lu(self) -> tuple[np.ndarray, np.ndarray]:
        """LU factors of the square ``S`` of the damped-oscillation design.

        Raises :class:`MethodNotApplicable` unless the applied input is the
        damped oscillation of this grid (with the thermal point when the
        thermal term is on), so that ``S`` is square and invertible.
        """
        L = self.grid.levels
        P = self.n_parameters
        design = "damped oscillation" + (" plus the thermal point" if self.thermal_term else "")
        if self.curves is not None and np.any(self.curves >= 0):
            raise MethodNotApplicable(
                f"does not apply to FORC data (first-order reversal curves): it needs the square {design} "
                f"design of the grid, {P} applied inputs on its walls for L={L}; use ls, smooth_nn or everett"
            )
        if self.n != P:
            raise MethodNotApplicable(
                f"needs the square {design} design: {P} applied inputs for L={L}, got {self.n}"
            )
        on_walls = self.grid.on_walls(self.inputs)
        if self.thermal_term:
            on_walls[-1] = True  # the thermal point is off-wall by design
        if not np.all(on_walls):
            k = int(np.flatnonzero(~on_walls)[0])
            raise MethodNotApplicable(
                f"input {k} ({self.inputs[k]:.6g}) is not on a wall of the {L}-level grid "
                f"on [{self.grid.v_min:g}, {self.grid.v_max:g}]; the {design} sits on the walls"
            )
        expected = damped_oscillation(self.grid, self.thermal_term)
        tol = 1e-9 * (self.grid.v_max - self.grid.v_min)
        if not np.allclose(self.inputs, expected, rtol=0, atol=tol):
            k = int(np.flatnonzero(~np.isclose(self.inputs, expected, rtol=0, atol=tol))[0])
            raise MethodNotApplicable(
                f"input {k} ({self.inputs[k]:.6g}) differs from the {design} "
                f"({expected[k]:.6g}) of this grid"
            )
        lu, piv = scipy.linalg.lu_factor(self.regressor, check_finite=False)
        anorm = np.abs(self.regressor).sum(axis=0).max()
        rcond, _ = scipy.linalg.lapack.dgecon(lu, anorm, norm="1")
        if rcond < SINGULAR_RCOND:
            raise MethodNotApplicable(f"the {design} matrix S is singular (rcond {rcond:.1e})")
        return lu, piv

    def solve_square(self, outputs: np.ndarray) -> np.ndarray:
        """``w = S^{-1} b`` for a full output vector ``b`` of length ``n``."""
        return scipy.linalg.lu_solve(self.square_lu, outputs, check_finite=False)

    def require_thermal_identifiable(self, method: str) -> None:
        """Reject a thermal term that the measured rows cannot identify.

        On the walls ``v`` is an affine function of the diagonal cells'
        signed areas (see :mod:`identify.excitation`), so when every
        measured input sits on a wall ``c_d`` cannot be told apart from a
        uniform shift of the diagonal cells.
        """
        if self.thermal_term and np.all(self.grid.on_walls(self.inputs[self.rows])):
            raise MethodNotApplicable(
                f"{method} cannot identify the thermal term: every measured input sits on a "
                "wall, where v is an affine function of the diagonal cells; measure an off-wall "
                "point (the damped oscillation's thermal point) or drop the thermal term"
            )

    def require_order(self, method: str) -> np.ndarray:
        if self.order is None:
            raise MethodNotApplicable(
                f"{method} needs the order of all {self.n} outputs, but only "
                f"{self.n_measured} were measured"
            )
        return self.order
