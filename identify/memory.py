"""The memory curve (staircase) of the Preisach plane and exact signed areas.

A hysteron with thresholds ``beta <= alpha`` is +1 when the input last left
``[beta, alpha]`` upwards and -1 when it last left downwards.  The set of
+1 hysterons is bounded by a staircase, the *memory curve*.  We store it as
its outer corners ``(a_k, b_k)``, ``k = 0..K-1``, in grid coordinates (see
:mod:`identify.grid`) with ``a_0 > a_1 > ... `` and ``b_0 < b_1 < ...`` and
``b_k <= a_k``.  The +1 region is the union of the quadrants::

    {(beta, alpha) : beta <= alpha, alpha < a_k, beta < b_k}

so for an alpha in ``[a_{k+1}, a_k)`` (``a_K = 0``) the hysterons with
``beta < min(b_k, alpha)`` are +1.  A last corner on the diagonal
(``b = a``) means the input last rose to ``a``.

Update rules (the wiping-out property):

* the input rises to ``x``: every corner with ``a_k <= x`` is wiped out and
  the corner ``(x, x)`` is appended;
* the input falls to ``x``: the first corner with ``b_k >= x`` gets
  ``b_k = x`` and every later corner is wiped out.

This is exact for *any* input value, not only for inputs on the walls.
"""

from __future__ import annotations

import bisect
from typing import Literal

import numpy as np

from .grid import Grid

InitialState = Literal["negative", "positive"]


class MemoryCurve:
    """The staircase of a ``levels``-level Preisach plane, in grid coordinates.

    Parameters
    ----------
    levels:
        Number of levels L; inputs are coordinates in ``[0, L]`` and are
        saturated into that range.
    initial:
        ``"negative"`` (all hysterons -1, input at 0; the default) or
        ``"positive"`` (all +1, input at L).
    """

    __slots__ = ("levels", "_a", "_b", "position")

    def __init__(self, levels: int, initial: InitialState = "negative") -> None:
        self.levels = int(levels)
        self._a: list[float] = []
        self._b: list[float] = []
        if initial == "negative":
            self.position = 0.0
        elif initial == "positive":
            self._a = [float(levels)]
            self._b = [float(levels)]
            self.position = float(levels)
        else:
            raise ValueError(f"initial state must be 'negative' or 'positive', got {initial!r}")

    def copy(self) -> "MemoryCurve":
        other = MemoryCurve.__new__(MemoryCurve)
        other.levels = self.levels
        other._a = list(self._a)
        other._b = list(self._b)
        other.position = self.position
        return other

    @property
    def corners(self) -> tuple[np.ndarray, np.ndarray]:
        """Corner coordinates ``(a, b)``, each shape ``(K,)``."""
        return np.array(self._a, dtype=float), np.array(self._b, dtype=float)

    def apply(self, x: float) -> int:
        """Move the input to coordinate ``x`` (saturated to ``[0, L]``).

        Returns the index of the first corner that changed: corners before
        it are untouched, corners from it on were replaced (``len(corners)``
        before the move when nothing changed).  Matrix-free operators use it
        to update only the part of the staircase that moved.
        """
        x = min(max(float(x), 0.0), float(self.levels))
        a, b = self._a, self._b
        k = len(a)
        if x > self.position:
            while k > 0 and a[k - 1] <= x:
                k -= 1
            del a[k:], b[k:]
            a.append(x)  # x > position >= 0, so the new corner is never empty
            b.append(x)
        elif x < self.position:
            k = 0
            while k < len(b) and b[k] < x:
                k += 1
            if k < len(b):
                del a[k + 1 :], b[k + 1 :]
                b[k] = x
            if b and b[-1] <= 0.0:
                a.pop()
                b.pop()
        self.position = x
        return k

    def plus_below(self, alpha: float) -> float:
        """At up-threshold ``alpha``: the hysterons with ``beta`` below this are +1 (0: none)."""
        k = bisect.bisect_left(self._a, -alpha, key=lambda a: -a)  # corners with a > alpha
        return min(self._b[k - 1], alpha) if k else 0.0

    def plus_left(self, beta: float) -> float:
        """At down-threshold ``beta``: the hysterons with ``alpha`` below this are +1 (``beta``: none)."""
        k = bisect.bisect_right(self._b, beta)  # first corner with b > beta
        return self._a[k] if k < len(self._a) else beta

    def tail(self, k: int) -> tuple[list[float], list[float]]:
        """Copies of the corners from index ``k`` on, as lists ``(a[k:], b[k:])``."""
        return self._a[k:], self._b[k:]

    def replay(self, xs: np.ndarray) -> None:
        """Apply a whole sequence of coordinates, in order."""
        for x in np.asarray(xs, dtype=float).ravel():
            self.apply(x)

    def signed_areas(self, grid: Grid) -> np.ndarray:
        """Signed area of every cell of ``grid``, shape ``(n_cells,)``, in [-1, 1]."""
        a, b = self.corners
        return signed_areas(grid, a, b)

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, MemoryCurve)
            and self.levels == other.levels
            and self._a == other._a
            and self._b == other._b
        )

    def __repr__(self) -> str:
        pts = ", ".join(f"({a:g}, {b:g})" for a, b in zip(self._a, self._b))
        return f"MemoryCurve(levels={self.levels}, position={self.position:g}, corners=[{pts}])"


class CellStates:
    """A memory curve together with the signed areas of every cell, kept up to date.

    Moving the input from ``p`` to ``x`` only changes hysterons with
    ``alpha`` in ``[p, x]`` (rising) or ``beta`` in ``[x, p]`` (falling):
    every hysteron with ``alpha`` below the input is already +1 and every
    one with ``beta`` above it already -1.  So only the cells in those bands
    are recomputed -- one row or column of cells per wall step.
    """

    __slots__ = ("grid", "curve", "areas")

    def __init__(self, grid: Grid, curve: MemoryCurve) -> None:
        self.grid = grid
        self.curve = curve
        self.areas = curve.signed_areas(grid)

    def apply(self, x: float) -> np.ndarray:
        """Move the input to coordinate ``x``; returns the (live) signed areas."""
        before = self.curve.position
        self.curve.apply(x)
        after = self.curve.position
        if after > before:
            cells = self.grid.cells_in_alpha_bands(int(np.floor(before)), int(np.ceil(after)))
        elif after < before:
            cells = self.grid.cells_in_beta_bands(int(np.floor(after)), int(np.ceil(before)))
        else:
            return self.areas
        a, b = self.curve.corners
        self.areas[cells] = signed_areas(self.grid, a, b, cells)
        return self.areas


def _band_integral(x: np.ndarray, lo: np.ndarray, top: np.ndarray) -> np.ndarray:
    """``integral_{-inf}^{x} (clip(t, lo, top) - lo) dt`` (elementwise, ``top >= lo``)."""
    width = top - lo
    below = np.clip(x, lo, top) - lo
    return 0.5 * below**2 + width * np.maximum(x - top, 0.0)


def signed_areas(
    grid: Grid, a: np.ndarray, b: np.ndarray, cells: slice | np.ndarray | None = None
) -> np.ndarray:
    """Exact signed areas ``s = (area(+) - area(-)) / area(cell)``.

    Parameters
    ----------
    grid:
        The discretisation (only ``levels`` and the cell numbering are used).
    a, b:
        Memory-curve corners in grid coordinates, shape ``(K,)`` each, as
        stored by :class:`MemoryCurve`.
    cells:
        Which cells (parameter indices or a slice); default all.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_cells,)`` (or of ``cells``) in parameter order, in ``[-1, 1]``.
    """
    if cells is None:
        cells = slice(None)
    area = grid.cell_area[cells]
    if len(a) == 0:
        return -np.ones(area.shape)
    i = grid.cell_alpha[cells].astype(float)[:, None]
    j = grid.cell_beta[cells].astype(float)[:, None]
    a = np.asarray(a, dtype=float)[None, :]
    b = np.asarray(b, dtype=float)[None, :]
    a_next = np.concatenate([a[:, 1:], np.zeros((1, 1))], axis=1)
    a0 = np.maximum(i, a_next)
    a1 = np.minimum(i + 1.0, a)
    top = np.clip(b, j, j + 1.0)
    band = _band_integral(a1, j, top) - _band_integral(a0, j, top)
    plus = np.where(a1 > a0, band, 0.0).sum(axis=1)
    return np.clip(2.0 * plus / area - 1.0, -1.0, 1.0)
