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
:class:`identify.diagnosis.scoring.Design`, a diagnosis candidate's columns.)

**The square design.**  The fast paths of ``cs``, ``cs_order``,
``cs_order_nn`` and ``cs_nodct`` need ``S`` square and invertible
(Proposition 1): the damped oscillation of the grid, plus with the thermal
term the thermal point (:mod:`identify.excitation`).
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
from .excitation import damped_oscillation
from .regressor import check_inputs, n_parameters
from .square import SquareSolver

#: Reciprocal condition number (1-norm) below which a square design counts as singular.
SINGULAR_RCOND = 1e-12

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

    # ---------------------------------------------------------- what it builds
    @cached_property
    def operator(self) -> RegressorOperator:
        """``S`` as a matrix-free operator, ``(n, P)`` (:mod:`identify.operators`), built once."""
        return RegressorOperator(self.grid, self.inputs, self.thermal_term, self.initial, self.history)

    @cached_property
    def _square(self) -> SquareSolver | str:
        """The square solver, or why this design has none (see the module docstring)."""
        reason = self._square_shape()
        if reason is not None:
            return reason
        try:
            return SquareSolver(self.operator)
        except IdentifyError as exc:  # SuperLU met an exactly zero pivot
            return str(exc)

    @property
    def square_solver(self) -> SquareSolver:
        """Sparse factorisation of the square design (:class:`~identify.square.SquareSolver`).

        Built once; raises :class:`MethodNotApplicable` with the reason
        when this is not the square design, or ``S`` is singular.
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
        """Raise :class:`MethodNotApplicable` unless this is the square damped-oscillation design."""
        reason = self._square_shape()
        if reason is not None:
            raise MethodNotApplicable(reason)

    def _square_shape(self) -> str | None:
        """Why ``S`` is not the square damped-oscillation design, or None."""
        grid, L, P = self.grid, self.grid.levels, self.n_parameters
        design = "damped oscillation" + (" plus the thermal point" if self.thermal_term else "")
        if not self.is_square:
            return f"needs the square {design} design: {P} applied inputs for L={L}, got {self.n}"
        on_walls = grid.on_walls(self.inputs)
        if self.thermal_term:
            on_walls[-1] = True  # the thermal point is off-wall by design
        if not np.all(on_walls):
            k = int(np.flatnonzero(~on_walls)[0])
            return (f"input {k} ({self.inputs[k]:.6g}) is not on a wall of the {L}-level grid "
                    f"on [{grid.v_min:g}, {grid.v_max:g}]; the {design} sits on the walls")
        expected = damped_oscillation(grid, self.thermal_term)
        tol = 1e-9 * (grid.v_max - grid.v_min)
        if not np.allclose(self.inputs, expected, rtol=0, atol=tol):
            k = int(np.flatnonzero(~np.isclose(self.inputs, expected, rtol=0, atol=tol))[0])
            return f"input {k} ({self.inputs[k]:.6g}) differs from the {design} ({expected[k]:.6g}) of this grid"
        return None

    def singular_reason(self, rcond: float) -> str:
        """Why the dense reference refuses this square design: ``S`` singular (``dgecon``'s ``rcond``)."""
        return f"the square design matrix S is singular (rcond {rcond:.1e})"
