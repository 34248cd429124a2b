"""The fast forward model: a model's output for any input, from its Everett function.

``u = mu0 + c_d v + 2 Phi - sum(mu)`` where ``Phi`` is the weight of the
switched-up hysterons, a sum of Everett terms over the corners of the
memory curve (:mod:`identify.everett`).  Two ways to use it:

* :func:`predict` -- a whole input sequence at once: the Everett increments
  of the sequence (``O(n)`` amortised) applied to the prefix table of the
  density, ``O(n + L^2)`` time and memory.  :meth:`PreisachModel.predict`
  uses it.
* :class:`HysteresisState` -- one input at a time, ``O(1)`` amortised
  Everett evaluations per step, with :meth:`~HysteresisState.peek` to ask
  "what would the output be if the input went to ``v`` now?" without moving
  the memory: what an inverse compensator searching for the input that
  gives a wanted output needs.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .errors import IdentifyError
from .everett import everett, everett_changes, everett_table, prefix_sums
from .grid import WALL_TOLERANCE, Grid
from .memory import InitialState, MemoryCurve
from .regressor import check_inputs, initial_curve


class Equation22(Protocol):
    """What the forward model reads of a model: equation (22)'s parameters.

    A :class:`identify.model.PreisachModel` is one; the forward model
    needs nothing else of it (its effects act on whole runs, above this
    module).
    """

    @property
    def grid(self) -> Grid: ...
    @property
    def density(self) -> np.ndarray:
        """Cell weights (um), ``(n_cells,)`` in the grid's parameter order."""
    @property
    def mu0(self) -> float:
        """The bias (um)."""
    @property
    def c_d(self) -> float:
        """The linear thermal coefficient (um/V)."""


def predict(
    model: Equation22,
    inputs: np.ndarray,
    initial: InitialState = "negative",
    history: np.ndarray | None = None,
) -> np.ndarray:
    """Output (um) of ``model`` for the input sequence ``inputs`` (V), shape ``(n,)``.

    The memory starts in the ``initial`` saturation, then sees ``history``;
    inputs beyond the grid range saturate.
    """
    v = check_inputs(inputs)
    grid = model.grid
    phi = np.cumsum(everett_changes(grid, grid.coordinates(v), initial_curve(grid, initial, history),
                                    prefix_sums(grid, model.density)))
    return 2.0 * phi - float(np.sum(model.density)) + model.mu0 + model.c_d * v


#: Points :func:`predict_many` replays at once (the replay's terms keep a few hundred bytes a point).
MANY_POINTS = 20_000


def predict_many(model: Equation22, inputs: np.ndarray) -> np.ndarray:
    """:func:`predict` of each row of ``inputs`` ``(k, n)`` (V) from negative saturation: ``(k, n)`` (um),
    the same numbers as ``k`` calls, in few replays.

    The rows are replayed one after another (up to :data:`MANY_POINTS`
    points at once), each after a fall to the grid's bottom (coordinate 0),
    which wipes the memory back to negative saturation: every later Everett
    term is then the one a fresh replay of the row makes, in the same order,
    so each row's increments (and their running sum, taken per row) are
    those of :func:`predict`.  The wipe's own row is dropped.  For many
    short sequences (the secants of a whole run, one per spline of a drift)
    this saves each replay's fixed cost.
    """
    v = np.asarray(inputs, dtype=float)
    if v.ndim != 2:
        raise IdentifyError(f"predict_many takes a (k, n) array of input sequences, got shape {v.shape}")
    check_inputs(v.ravel())
    grid = model.grid
    k, n = v.shape
    xs = np.zeros((k, n + 1))
    xs[:, 1:] = grid.coordinates(v)
    p = prefix_sums(grid, model.density)
    steps = np.empty((k, n + 1))
    rows = max(1, MANY_POINTS // (n + 1))
    for r in range(0, k, rows):
        part = xs[r:r + rows]
        changes = everett_changes(grid, part.ravel(), MemoryCurve(grid.levels, "negative"), p)
        steps[r:r + rows] = changes.reshape(part.shape)
    phi = np.cumsum(steps[:, 1:], axis=1)
    return 2.0 * phi - float(np.sum(model.density)) + model.mu0 + model.c_d * v


def _phi_terms(a: list[float], b: list[float], prev: float) -> list[tuple[float, float, float]]:
    """``(sign, x, y)`` of the Everett terms of corners ``(a, b)`` following a corner with ``b = prev``."""
    terms = []
    for ak, bk in zip(a, b):
        terms.append((1.0, ak, bk))
        terms.append((-1.0, ak, prev))
        prev = bk
    return terms


class HysteresisState:
    """A model and its memory, stepped one input at a time.

    Parameters
    ----------
    model: the model's equation (22) (:class:`Equation22`, e.g. a
        :class:`~identify.model.PreisachModel`).
    initial, history: the memory before the first input (as for
        :meth:`PreisachModel.predict`).
    """

    def __init__(
        self,
        model: Equation22,
        initial: InitialState = "negative",
        history: np.ndarray | None = None,
    ) -> None:
        self.model = model
        self._table = everett_table(model.grid, model.density).tolist()
        self._total = float(np.sum(model.density))
        self.curve: MemoryCurve = initial_curve(model.grid, initial, history)
        a, b = self.curve.tail(0)
        self._phi = self._sum(_phi_terms(a, b, 0.0))
        self._v = model.grid.v_min + model.grid.step * self.curve.position

    def _sum(self, terms: list[tuple[float, float, float]]) -> float:
        return sum(s * everett(self._table, x, y) for s, x, y in terms)

    def _moved(self, curve: MemoryCurve, x: float) -> float:
        """``Phi`` after moving ``curve`` (which is changed) to coordinate ``x``."""
        old_a, old_b = curve.tail(0)
        k = curve.apply(x)
        new_a, new_b = curve.tail(k)
        prev = old_b[k - 1] if k else 0.0
        return self._phi - self._sum(_phi_terms(old_a[k:], old_b[k:], prev)) + self._sum(
            _phi_terms(new_a, new_b, prev)
        )

    def _output(self, phi: float, v: float) -> float:
        m = self.model
        return 2.0 * phi - self._total + m.mu0 + m.c_d * v

    @property
    def output(self) -> float:
        """The output (um) at the current input."""
        return self._output(self._phi, self._v)

    def _coordinate(self, v: float) -> float:
        """Grid coordinate of ``v`` (V), as :meth:`Grid.coordinates` but for one value."""
        g = self.model.grid
        x = min(max((float(v) - g.v_min) / g.step, 0.0), float(g.levels))
        r = round(x)
        return float(r) if abs(x - r) <= WALL_TOLERANCE else x

    def peek(self, v: float) -> float:
        """The output (um) if the input moved to ``v`` (V) now; the memory is not changed."""
        return self._output(self._moved(self.curve.copy(), self._coordinate(v)), float(v))

    def apply(self, v: float) -> float:
        """Move the input to ``v`` (V); returns the new output (um)."""
        self._phi = self._moved(self.curve, self._coordinate(v))
        self._v = float(v)
        return self.output
