"""The design of an identification: everything the regressor ``S`` depends on, as one value.

``S`` (equation 22) is a function of the grid, the applied input sequence
(V), whether the thermal term is fitted, and the memory before the first
input (a saturation, then a history) -- not of the measured outputs or of
which rows were measured.  A :class:`Design` is that value.  Two designs
with the same grid, thermal term, initial state and input and history
values are equal and hash alike; the arrays are private read-only copies,
so changing the caller's arrays afterwards changes nothing.

A design owns what depends on it alone and builds each on first use:

* :attr:`Design.operator` -- ``S`` as a matrix-free
  :class:`~identify.operators.RegressorOperator` (the memory curve replayed
  once);
* :attr:`Design.square_solver` -- on a square design whose ``S`` is
  invertible, the sparse factorisation and sparse ``S^{-1}``
  (:mod:`identify.square`);

Fits on one design share them: build each
:class:`~identify.methods.Problem` with ``Problem.on(design, outputs,
rows)`` (another ``M`` or seed, the study's runs, the methods compared on one
data set, ``rig bench``'s repeats).  Nothing is kept process-wide: what a
design built lives as long as the design.  (Not to be confused with
:class:`identify.cross_validation.Design`, a diagnosis candidate's columns.)

**The square design.**  The fast paths of ``cs``, ``cs_order``,
``cs_order_nn`` and ``cs_nodct`` need ``S`` square and invertible: as many
applied inputs as equation (22) has parameters (Proposition 1: the damped
oscillation, plus with the thermal term one more point).  Any such design
is accepted -- the damped oscillation in another order (e.g. from the
bottom up), the thermal point anywhere that keeps ``S`` invertible (off the
walls, or beyond the range where only ``c_d v`` changes) -- and checked:

1. with the thermal term, a design whose inputs all sit on walls is refused
   without numerics: there ``v`` is an affine function of the diagonal
   cells' signed areas (:mod:`identify.excitation`), so ``S`` is singular
   whatever the order;
2. otherwise ``S`` is factorised sparsely and its reciprocal condition
   number estimated from a few solves
   (:meth:`~identify.square.SquareSolver.reciprocal_condition`); below
   :data:`SINGULAR_RCOND` the design is refused, naming the parameters it
   cannot tell apart.  The dense reference paths check their dense LU the
   same way (LAPACK's ``dgecon``; :attr:`identify.methods.Problem.square_lu`,
   which, like the dense ``S``, belongs to the problem, not the design).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse

from .errors import IdentifyError, MethodNotApplicable
from .grid import Grid
from .memory import InitialState
from .operators import RegressorOperator
from .regressor import check_inputs, initial_curve, n_parameters
from .square import SquareSolver

#: Reciprocal condition number (1-norm) below which a square design counts as singular.
SINGULAR_RCOND = 1e-12

#: Up to how many cells a singular design cannot tell apart are named in the refusal (more are counted).
NAMED_CELLS = 3


def thermal_point_row(grid: Grid, inputs: np.ndarray) -> int | None:
    """The thermal point of a square thermal-term design: its row, or None.

    A design with as many inputs ``(n,)`` (V) as equation (22) with the
    thermal term has parameters, all on the walls of ``grid`` but one: that
    one is the thermal point, the only row through which ``c_d`` can be
    identified (on the walls ``v`` is affine in the diagonal cells).  The
    damped oscillation plus the thermal point gives its last row.
    """
    v = np.asarray(inputs, dtype=float)
    if v.shape != (n_parameters(grid, True),):
        return None
    off = np.flatnonzero(~grid.on_walls(v))
    return int(off[0]) if off.size == 1 else None


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False, repr=False)
class Design:
    """Grid, applied inputs ``(n,)`` (V), thermal term, initial saturation and history ``(h,)`` (V).

    A value: equal designs compare and hash equal.  ``S`` is ``(n, P)`` with
    ``P = n_cells + 1 (+ 1 with the thermal term)``; see the module
    docstring for what a design builds and how the square design is checked.
    Raises :class:`IdentifyError` for inputs that are not a finite 1-D sequence.
    """

    grid: Grid
    inputs: np.ndarray
    thermal_term: bool = True
    initial: InitialState = "negative"
    history: np.ndarray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "inputs", _frozen(check_inputs(self.inputs)))
        if self.history is not None:
            set_(self, "history", _frozen(check_inputs(self.history, "history input")))
        set_(self, "thermal_term", bool(self.thermal_term))

    @cached_property
    def _key(self) -> tuple:
        history = None if self.history is None else self.history.tobytes()
        return (self.grid, self.thermal_term, self.initial, self.inputs.tobytes(), history)

    def __eq__(self, other: object) -> bool:
        return self is other or (isinstance(other, Design) and self._key == other._key)

    def __hash__(self) -> int:
        return hash(self._key)

    def __reduce__(self):
        # what a design built (SuperLU's factors) cannot be pickled: a copy rebuilds it on first use
        return (Design, (self.grid, self.inputs, self.thermal_term, self.initial, self.history))

    def __repr__(self) -> str:
        history = "" if self.history is None else f", history of {self.history.size}"
        return (f"Design({self.grid!r}, {self.n} inputs, thermal_term={self.thermal_term}, "
                f"initial={self.initial!r}{history})")

    # ---------------------------------------------------------- dimensions
    @property
    def n(self) -> int:
        """Number of applied inputs (rows of ``S``)."""
        return int(self.inputs.size)

    @property
    def n_parameters(self) -> int:
        """Length of ``w``: cells, ``mu0`` and (with the thermal term) ``c_d``."""
        return n_parameters(self.grid, self.thermal_term)

    @property
    def is_square(self) -> bool:
        """Whether ``S`` is square (``n == P``); invertible or not, see :attr:`square_solver`."""
        return self.n == self.n_parameters

    @cached_property
    def thermal_row(self) -> int | None:
        """The row of the thermal point (see :func:`thermal_point_row`), or None; always None without
        the thermal term."""
        return thermal_point_row(self.grid, self.inputs) if self.thermal_term else None

    # ---------------------------------------------------------- what it builds
    @cached_property
    def operator(self) -> RegressorOperator:
        """``S`` as a matrix-free operator, ``(n, P)`` (:mod:`identify.operators`), built once."""
        return RegressorOperator(self.grid, self.inputs, self.thermal_term, self.initial, self.history)

    def adopt(self, operator: RegressorOperator) -> "Design":
        """Take ``operator``, built elsewhere for these very inputs, as :attr:`operator` (unless one is
        built already); returns ``self``.  Raises :class:`ValueError` for an operator of another design."""
        if "operator" not in self.__dict__:
            same = (operator.grid == self.grid and operator.thermal_term == self.thermal_term
                    and np.array_equal(operator.inputs, self.inputs)
                    and operator.start == initial_curve(self.grid, self.initial, self.history))
            if not same:
                raise ValueError("the operator was built for another design")
            self.__dict__["operator"] = operator
        return self

    @cached_property
    def _square(self) -> SquareSolver | str:
        """The square solver, or why this design has none (see the module docstring)."""
        reason = self._square_shape()
        if reason is not None:
            return reason
        try:
            solver = SquareSolver(self.operator)
        except IdentifyError:  # SuperLU met an exactly zero pivot
            return self.singular_reason(None)
        rcond, direction = solver.reciprocal_condition()
        if rcond < SINGULAR_RCOND:
            return self.singular_reason(rcond, direction)
        return solver

    @property
    def square_solver(self) -> SquareSolver:
        """Sparse factorisation of the square design (:class:`~identify.square.SquareSolver`).

        Built and checked once; raises :class:`MethodNotApplicable` with the
        reason when ``S`` is not square or not invertible.
        """
        solver = self._square
        if isinstance(solver, str):
            raise MethodNotApplicable(solver)
        return solver

    @property
    def sparse_inverse(self) -> scipy.sparse.csr_array:
        """The explicit sparse ``S^{-1}``, ``(P, n)``, about ``4 n`` non-zeros (square design)."""
        return self.square_solver.inverse

    def solve(self, outputs: np.ndarray) -> np.ndarray:
        """``w = S^{-1} b`` for outputs ``b`` ``(n,)`` or ``(n, k)`` (um) by the sparse factorisation."""
        return self.square_solver.solve(outputs)

    # ---------------------------------------------------------- reasons
    def require_square_shape(self) -> None:
        """Raise :class:`MethodNotApplicable` when ``S`` cannot be square and invertible, before any
        numerics: not square, or (with the thermal term) every input on a wall."""
        reason = self._square_shape()
        if reason is not None:
            raise MethodNotApplicable(reason)

    def _square_shape(self) -> str | None:
        """Why ``S`` cannot be square and invertible before any numerics, or None."""
        grid, P = self.grid, self.n_parameters
        if not self.is_square:
            design = "the damped oscillation" + (" plus a thermal point" if self.thermal_term else "")
            return (f"needs a square design, as many applied inputs as equation (22) has parameters "
                    f"({design}): {P} for L={grid.levels}, got {self.n}")
        if self.thermal_term and np.all(grid.on_walls(self.inputs)):
            return (f"needs an invertible S, but every input of this square design sits on a wall of the "
                    f"{grid.levels}-level grid on [{grid.v_min:g}, {grid.v_max:g}], the thermal point's "
                    "included: on the walls v is an affine function of the diagonal cells' signed areas, "
                    "so S is singular; put the thermal point off the walls (e.g. half a cell above the "
                    "last point) or beyond the range")
        return None

    def singular_reason(self, rcond: float | None, direction: np.ndarray | None = None) -> str:
        """Why this square design is refused: ``S`` singular, with reciprocal condition number
        ``rcond`` (None: the sparse factorisation met an exactly zero pivot).  ``direction`` ``(P,)``,
        a column of the computed ``S^{-1}`` (:meth:`~identify.square.SquareSolver.reciprocal_condition`),
        names the parameters that ``S`` cannot tell apart: those with a sizeable entry in it."""
        if rcond is None:
            why = "its sparse factorisation meets an exactly zero pivot"
        else:
            why = f"reciprocal condition number {rcond:.1e}, below {SINGULAR_RCOND:g}"
        head = f"needs an invertible S, but this square design's is singular ({why})"
        if direction is None or not np.all(np.isfinite(direction)) or not np.any(direction):
            return head
        size = np.abs(direction)
        involved = np.flatnonzero(size >= 1e-3 * size.max())
        c = self.grid.n_cells
        cells = involved[involved < c]
        names = ([self.parameter_name(int(k)) for k in cells] if cells.size <= NAMED_CELLS
                 else [f"{cells.size} cells"])
        names += [self.parameter_name(int(k)) for k in involved[involved >= c]]
        apart = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
        return f"{head}: it cannot tell apart {apart}"

    def parameter_name(self, k: int) -> str:
        """What entry ``k`` of ``w`` is: ``cell (i, j)`` (alpha band i, beta band j from v_min), ``mu0`` or ``c_d``."""
        c = self.grid.n_cells
        if k < c:
            return f"cell ({int(self.grid.cell_alpha[k])}, {int(self.grid.cell_beta[k])})"
        return "mu0" if k == c else "c_d"
