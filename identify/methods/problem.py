"""An identification problem: the regressor, which rows were measured, and what.

The whole applied input sequence defines the regressor ``S`` (every row's
memory state depends on everything applied before it); only the rows in
``rows`` were measured (``A`` in equation (12) selects them).

What ``S`` depends on -- grid, inputs, thermal term, initial memory -- is
the problem's :class:`~identify.regressor_design.Design`, which builds and owns the
matrix-free ``operator`` (:mod:`identify.operators`) and, on a square
design, the ``square_solver`` / ``sparse_inverse`` (:mod:`identify.square`)
that the fast solvers use; problems built on one design
(:meth:`Problem.on`) share them.  Nothing large is built up front: the dense
``regressor`` and ``square_lu`` only when a dense (reference) path asks for
them -- at L = 200 the dense ``S`` would take 3.2 GB.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse
from scipy.sparse.linalg import LinearOperator

from ..regressor_design import SINGULAR_RCOND, Design
from ..errors import IdentifyError, MethodNotApplicable
from ..grid import Grid
from ..memory import InitialState
from ..operators import AugmentedOperator, RegressorOperator, RowScaledOperator
from ..regressor import n_parameters, regressor_matrix
from ..square import SquareSolver


def _of_design(name: str, doc: str) -> property:
    """A read-only attribute of the problem that is its design's ``name``."""
    return property(lambda self: getattr(self.design, name), doc=doc)


@dataclass(frozen=True, eq=False)
class Problem:
    """What every method gets.

    Attributes
    ----------
    design: the :class:`~identify.regressor_design.Design` -- grid, the whole applied
        input sequence, thermal term, initial memory -- that ``S`` depends
        on; ``grid``, ``inputs`` ``(n,)`` (V), ``thermal_term``, ``initial``
        and ``history`` read it.
    rows: ``(M,)`` sorted indices of the measured rows.
    measured: ``(M,)`` the outputs measured at ``rows`` (um).
    order: ``(n,)`` the permutation sorting all ``n`` outputs ascending,
        when all of them are known (needed by the ``cs_order`` methods), else
        ``None``.
    curves: ``(n,)`` the curve each applied row belongs to (-1: none), for
        inputs made of first-order reversal curves (needed by ``everett``),
        else ``None``.
    extra: ``(n, k)`` extra columns fitted jointly with the density (the
        terms of unmodelled effects, :mod:`identify.effects`; output units
        per unit coefficient), or ``None``; the first ``extra_nonneg`` of
        their coefficients are >= 0, the others free.  With extra columns
        ``operator`` is an :class:`~identify.operators.AugmentedOperator`
        and the parameter vector is ``(cells, extra >= 0, mu0[, c_d], extra free)``.
    row_scale: ``(n,)`` or ``None``: every row of the design (regressor and
        extra columns) multiplied by it -- the joint fit's Gauss--Newton step
        through a sensor map (:mod:`identify.effects.joint`).
    penalty: ``(r, k)`` or ``None``: rows acting on the extra columns'
        coefficients alone, appended to the design and fitted to zero (a
        roughness penalty); they are rows ``n .. n + r - 1`` of ``operator``
        and are among ``rows`` (``measured`` there is ``penalty_target``, zeros
        by default), so ``n_rows = n + r``.

    ``operator`` (``S`` as a matrix-free
    :class:`~identify.operators.RegressorOperator`, the design's) and
    ``regressor`` (the dense ``S``, ``(n, P)``, this problem's) are built on
    first use.
    """

    design: Design
    rows: np.ndarray
    measured: np.ndarray
    order: np.ndarray | None = None
    dense: np.ndarray | None = field(default=None, repr=False)
    curves: np.ndarray | None = None
    extra: np.ndarray | None = field(default=None, repr=False)
    extra_nonneg: int = 0
    row_scale: np.ndarray | None = field(default=None, repr=False)
    penalty: np.ndarray | None = field(default=None, repr=False)

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
        **options: Any,
    ) -> "Problem":
        """A problem from the applied inputs (V) and the outputs (um) of every row, on a new design.

        ``Problem.on(Design(grid, inputs, thermal_term, initial, history), outputs, rows, **options)``:
        ``options`` are :meth:`on`'s keywords (``regressor``, ``curves``, ``extra``, ...).
        """
        return cls.on(Design(grid, inputs, thermal_term, initial, history), outputs, rows, **options)

    @classmethod
    def on(
        cls,
        design: Design,
        outputs: np.ndarray,
        rows: np.ndarray | None = None,
        *,
        regressor: np.ndarray | None = None,
        curves: np.ndarray | None = None,
        extra: np.ndarray | None = None,
        extra_nonneg: int = 0,
        row_scale: np.ndarray | None = None,
        penalty: np.ndarray | None = None,
        penalty_target: np.ndarray | None = None,
    ) -> "Problem":
        """A problem on ``design`` from the outputs (um) of its ``n`` applied inputs.

        Problems on one design share its operator and square solver (built
        once, on first use).  ``outputs`` ``(n,)`` may hold NaN at rows that
        were not measured; ``rows`` defaults to every row with a finite
        output.  When every output is known, ``order`` is their ascending
        sort (the paper's assumption for 'CS Order').  ``regressor`` (the
        dense ``S``) may be passed when already computed; otherwise nothing
        is built until a method asks.  ``curves`` ``(n,)`` numbers the curve
        of every applied row (-1: none).  ``extra`` ``(n, k)`` are extra
        columns fitted jointly (see the class doc), the first
        ``extra_nonneg`` of them with coefficients >= 0.
        """
        v = design.inputs
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
        if regressor is not None and regressor.shape != (v.size, design.n_parameters):
            raise IdentifyError("regressor shape does not match the inputs and grid")
        if curves is not None:
            curves = np.asarray(curves)
            if curves.shape != v.shape or (curves.size and not np.issubdtype(curves.dtype, np.integer)):
                raise IdentifyError(f"curve index must be {v.size} whole numbers, one per input")
            curves = curves.astype(np.int64)
        if extra is not None:
            extra = np.asarray(extra, dtype=float)
            if extra.ndim != 2 or extra.shape[0] != v.size or not np.all(np.isfinite(extra)):
                raise IdentifyError(f"extra columns must be a finite ({v.size}, k) array")
            if not 0 <= extra_nonneg <= extra.shape[1]:
                raise IdentifyError(f"extra_nonneg={extra_nonneg} outside 0..{extra.shape[1]}")
            if regressor is not None:
                raise IdentifyError("a dense regressor cannot be combined with extra columns")
        if row_scale is not None:
            row_scale = np.asarray(row_scale, dtype=float)
            if row_scale.shape != v.shape or not np.all(np.isfinite(row_scale)):
                raise IdentifyError(f"row scale must be {v.size} finite numbers")
            if regressor is not None:
                raise IdentifyError("a dense regressor cannot be combined with a row scale")
        order = np.argsort(y, kind="stable") if np.all(known) else None
        measured = y[rows].copy()
        if penalty is not None:
            penalty = np.asarray(penalty, dtype=float)
            if extra is None or penalty.ndim != 2 or penalty.shape[1] != extra.shape[1]:
                raise IdentifyError("penalty rows need extra columns of the same width")
            rows = np.concatenate([rows, v.size + np.arange(penalty.shape[0])])
            target = np.zeros(penalty.shape[0]) if penalty_target is None else np.asarray(penalty_target, float)
            if target.shape != (penalty.shape[0],):
                raise IdentifyError("the penalty target needs one value per penalty row")
            measured = np.concatenate([measured, target])
            order = None
        return cls(design, rows, measured, order, regressor, curves,
                   extra, int(extra_nonneg) if extra is not None else 0, row_scale, penalty)

    # ---------------------------------------------------------- the design
    grid = _of_design("grid", "The discretisation (:class:`~identify.grid.Grid`).")
    inputs = _of_design("inputs", "``(n,)`` the whole applied input sequence (V), read-only.")
    thermal_term = _of_design("thermal_term", "Whether ``S`` has the ``c_d`` column.")
    initial = _of_design("initial", "The saturation before the first input (``negative`` or ``positive``).")
    history = _of_design("history", "The inputs (V) applied after that saturation and before the first one, or None.")

    # ---------------------------------------------------------- dimensions
    @property
    def n(self) -> int:
        """Number of applied inputs (rows of ``S``)."""
        return self.inputs.size

    @property
    def n_measured(self) -> int:
        return self.rows.size

    @property
    def n_rows(self) -> int:
        """Rows of ``operator``: the applied inputs, then the penalty rows (if any)."""
        return self.n + (0 if self.penalty is None else int(self.penalty.shape[0]))

    @property
    def n_parameters(self) -> int:
        return n_parameters(self.grid, self.thermal_term) + self.n_extra

    @property
    def n_extra(self) -> int:
        """Number of extra columns (effect terms), 0 without."""
        return 0 if self.extra is None else int(self.extra.shape[1])

    @property
    def n_nonneg(self) -> int:
        """How many leading parameters are >= 0: the cells, then the sign-constrained extras."""
        return self.grid.n_cells + self.extra_nonneg

    def split(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``w`` as (the model's parameters ``(cells, mu0[, c_d])``, the extra columns' coefficients ``(k,)``)."""
        w = np.asarray(w, dtype=float)
        if self.extra is None:
            return w, np.zeros(0)
        op = self.operator
        return w[op.base_index], w[op.extra_index]

    @property
    def n_cells(self) -> int:
        return self.grid.n_cells

    # ---------------------------------------------------------- the regressor
    @cached_property
    def operator(self) -> RegressorOperator | AugmentedOperator:
        """``S`` as a matrix-free operator (``matvec`` = ``S w``, ``rmatvec`` = ``S^T r``).

        ``O(n + L^2)`` per product and in memory (:mod:`identify.operators`);
        ``operator.rows(problem.rows)`` is ``A S``.  Solvers that only need
        products use this, so they scale to large L.  It is the design's
        operator (shared by the problems on the design), augmented with the
        extra columns and row scale when there are any.
        """
        base = self.design.operator
        op = base if self.extra is None else AugmentedOperator(base, self.extra, self.extra_nonneg, self.penalty)
        if self.row_scale is None:
            return op
        scale = np.concatenate([self.row_scale, np.ones(self.n_rows - self.n)])
        return RowScaledOperator(op, scale)

    @property
    def measured_operator(self) -> LinearOperator:
        """``A S`` as an operator, shape ``(M, P)``."""
        return self.operator.rows(self.rows)

    @cached_property
    def regressor(self) -> np.ndarray:
        """The dense ``S``, shape ``(n, P)``: built on first use (dense paths only)."""
        if self.dense is not None:
            return self.dense
        if self.extra is not None or self.row_scale is not None:
            return self.operator.dense_rows()
        return regressor_matrix(self.grid, self.inputs, self.thermal_term, self.initial, self.history)

    @property
    def measured_regressor(self) -> np.ndarray:
        """``A S``: the rows of the dense ``S`` that were measured, shape ``(M, P)``."""
        return self.regressor[self.rows]

    def fitted(self, w: np.ndarray) -> np.ndarray:
        """``S w`` (um) at every applied input, ``(n,)``, without the dense ``S``."""
        return self.operator.matvec(np.asarray(w, dtype=float))

    # ---------------------------------------------------------- square design
    def require_square(self, solver: str = "fast") -> None:
        """Raise :class:`MethodNotApplicable` with the reason unless ``S`` is square and invertible.

        Any square design whose ``S`` is invertible will do -- the damped
        oscillation in any order, the thermal point anywhere that keeps
        ``S`` invertible -- checked numerically by the path that will solve
        with ``S``: the design's sparse factorisation (``solver="fast"``) or
        this problem's dense LU (``"dense"``, :attr:`square_lu`); see
        :mod:`identify.regressor_design`.
        """
        if solver == "dense":
            self.square_lu
        else:
            self._require_square_kind()
            self.design.square_solver

    def _require_square_kind(self) -> None:
        """Refuse extra columns and FORC data before anything else, saying what to use instead."""
        if self.extra is not None:
            raise MethodNotApplicable(
                f"cannot fit effects jointly: it needs the square damped-oscillation design, which has exactly "
                f"as many inputs as equation (22) has parameters and no room for the {self.n_extra} effect "
                "term(s); use ls or smooth_nn"
            )
        if self.curves is not None and np.any(self.curves >= 0):
            design = "damped oscillation" + (" plus the thermal point" if self.thermal_term else "")
            raise MethodNotApplicable(
                f"does not apply to FORC data (first-order reversal curves): it needs the square {design} "
                f"design of the grid, {self.n_parameters} applied inputs on its walls for "
                f"L={self.grid.levels}; use ls, smooth_nn or everett"
            )

    @cached_property
    def square_lu(self) -> tuple[np.ndarray, np.ndarray]:
        """Dense LU factors of the square ``S`` (the dense reference path).

        Raises :class:`MethodNotApplicable` unless the design is square and
        ``S`` is numerically invertible (reciprocal condition number by
        LAPACK's ``dgecon`` at least :data:`identify.regressor_design.SINGULAR_RCOND`).
        """
        self._require_square_kind()
        self.design.require_square_shape()
        with warnings.catch_warnings():  # an exactly singular S is refused below, with the reason
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            lu, piv = scipy.linalg.lu_factor(self.regressor, check_finite=False)
        anorm = np.abs(self.regressor).sum(axis=0).max()
        rcond, _ = scipy.linalg.lapack.dgecon(lu, anorm, norm="1")
        if not rcond >= SINGULAR_RCOND:
            raise MethodNotApplicable(self.design.singular_reason(float(rcond)))
        return lu, piv

    @property
    def square_solver(self) -> SquareSolver:
        """Sparse factorisation of the square design (:class:`~identify.square.SquareSolver`).

        The design's: shared, with its sparse ``S^{-1}``, by the problems on
        the same design.  Raises like :meth:`require_square`.
        """
        self._require_square_kind()
        return self.design.square_solver

    @property
    def sparse_inverse(self) -> scipy.sparse.csr_array:
        """The explicit sparse ``S^{-1}``, ``(P, n)``, about ``4 n`` non-zeros (square design)."""
        return self.square_solver.inverse

    def solve_square(self, outputs: np.ndarray, solver: str = "fast") -> np.ndarray:
        """``w = S^{-1} b`` for a full output vector ``b`` of length ``n``.

        ``solver="fast"`` uses the design's sparse factorisation, ``"dense"``
        the dense LU of ``S``.
        """
        if solver == "dense":
            return scipy.linalg.lu_solve(self.square_lu, outputs, check_finite=False)
        return self.square_solver.solve(outputs)

    def require_thermal_identifiable(self, method: str) -> None:
        """Reject a thermal term that the measured rows cannot identify.

        On the walls ``v`` is an affine function of the diagonal cells'
        signed areas (see :mod:`identify.excitation`), so when every
        measured input sits on a wall ``c_d`` cannot be told apart from a
        uniform shift of the diagonal cells.
        """
        if self.thermal_term and np.all(self.grid.on_walls(self.inputs[self.rows[self.rows < self.n]])):
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
