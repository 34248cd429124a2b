"""The Preisach part of a model along a monotone move of its input, piece by piece, from the present memory.

From the present memory curve (corners ``(a_k, b_k)``, input at ``p``; see
:mod:`identify.memory`) the input can move up or down.  Moving **up** to
``x`` wipes out the corners with ``a_k <= x`` and adds ``(x, x)``; moving
**down** to ``x`` sets ``b_k = x`` at the first corner with ``b_k >= x``
and wipes out the rest.  With the Everett function ``F``
(:mod:`identify.everett`) the weight of the switched-up hysterons is then::

    up:    Phi(x) = C_m + F(x, x) - F(x, b_{m-1})          m = #{k : a_k > x}
    down:  Phi(x) = C_k - F(a_k, b_{k-1}) + F(a_k, x)       k = min{k : b_k >= x}

with ``C_k`` the sum of the first ``k`` corners' terms (``b_{-1} = 0``).  Between
two walls of the grid and two corners of the memory curve ``m`` (or ``k``)
is fixed, ``F(x, x)`` and ``F(a, x)`` are quadratics of ``x`` and
``F(x, b)`` is linear, so the Preisach part ``P = 2 Phi - sum(mu)`` of
equation (22) is a quadratic of ``x`` on each such piece, with coefficients
read from the Everett table.  Beyond the grid it is constant (``+sum(mu)``
above, ``-sum(mu)`` below).

:class:`PreisachPath` yields those pieces, nearest first, and moves the
memory exactly as :class:`identify.memory.MemoryCurve` does (it keeps one).
Coordinates are grid coordinates (walls at the integers ``0..L``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from ..everett import everett, everett_table
from ..grid import Grid
from ..memory import MemoryCurve

#: A piece of the move: ``(start, end, cell, p0, p1, p2)``: on ``x = cell + f`` between ``start`` and ``end``
#: (grid coordinates; ``end < start`` moving down) ``P = p0 + p1 f + p2 f^2`` (output units).
Piece = tuple[float, float, int, float, float, float]


class PreisachPath:
    """The Preisach part of equation (22) with its memory curve, for one input at a time.

    Parameters
    ----------
    grid, density: the model's grid and cell weights ``(n_cells,)`` (um).
    curve: the memory before the first move (copied).
    """

    __slots__ = ("levels", "total", "curve", "_t", "_c")

    def __init__(self, grid: Grid, density: np.ndarray, curve: MemoryCurve) -> None:
        self.levels = grid.levels
        self.total = float(np.sum(density))
        self._t = everett_table(grid, density).tolist()
        self.curve = curve.copy()
        self._c = [0.0]
        self._extend(0)

    def copy(self) -> "PreisachPath":
        other = PreisachPath.__new__(PreisachPath)
        other.levels, other.total, other._t = self.levels, self.total, self._t
        other.curve = self.curve.copy()
        other._c = list(self._c)
        return other

    # ------------------------------------------------------------ the memory
    def _extend(self, k: int) -> None:
        """Recompute the corner sums ``C`` from corner ``k`` on."""
        a, b = self.curve.tail(0)
        c = self._c
        del c[k + 1 :]
        t = self._t
        for j in range(k, len(a)):
            prev = b[j - 1] if j else 0.0
            c.append(c[j] + everett(t, a[j], b[j]) - everett(t, a[j], prev))

    @property
    def position(self) -> float:
        """The input's grid coordinate now."""
        return self.curve.position

    @property
    def value(self) -> float:
        """The Preisach part ``P`` now (um)."""
        return 2.0 * self._c[-1] - self.total

    def apply(self, x: float) -> float:
        """Move the input to coordinate ``x`` (saturated to ``[0, L]``); returns the new ``P`` (um)."""
        k = self.curve.apply(x)
        self._extend(min(k, len(self._c) - 1))
        return self.value

    # ------------------------------------------------------------ pieces of a move
    def pieces(self, up: bool, end: float) -> Iterator[Piece]:
        """The pieces of the move from the present input to coordinate ``end`` (which may lie beyond the
        grid), nearest first; ``up`` says the direction (``end`` above the input, else below)."""
        return self._up(end) if up else self._down(end)

    def _up(self, end: float) -> Iterator[Piece]:
        a, b = self.curve.tail(0)
        t, c, L = self._t, self._c, self.levels
        s = self.curve.position
        m = len(a)
        while m and a[m - 1] <= s:
            m -= 1
        while s < end:
            if s >= L:
                yield s, end, L, self.total, 0.0, 0.0
                return
            i = int(s)
            e = min(float(i + 1), end)
            if m and a[m - 1] < e:
                e = a[m - 1]
            ti, tk = t[i], t[i + 1]
            d0, d1, d2 = ti[i], tk[i] - ti[i], tk[i + 1] - tk[i]
            f0 = f1 = 0.0
            if m:
                y = b[m - 1]
                j = min(int(y), L - 1)
                fy = y - j
                mu = t[j + 1][j + 1] - t[j + 1][j]
                lo = (1.0 - fy) * ti[j] + fy * ti[j + 1]
                hi = (1.0 - fy) * tk[j] + fy * tk[j + 1]
                if i > j:
                    f0, f1 = lo + fy * (1.0 - fy) * mu, hi - lo
                else:
                    f0, f1 = lo - fy * fy * mu, hi - lo + fy * mu
            yield s, e, i, 2.0 * (c[m] + d0 - f0) - self.total, 2.0 * (d1 - f1), 2.0 * d2
            if m and e == a[m - 1]:
                m -= 1
            s = e

    def _down(self, end: float) -> Iterator[Piece]:
        a, b = self.curve.tail(0)
        t, c, L = self._t, self._c, self.levels
        s = self.curve.position
        n = len(b)
        k = 0
        while k < n and b[k] < s:
            k += 1
        base_k, base = -1, 0.0
        while s > end:
            if s <= 0.0 or k >= n:
                yield s, end, 0, -self.total, 0.0, 0.0
                return
            j = math.ceil(s) - 1
            e = max(float(j), end)
            if k and b[k - 1] > e:
                e = b[k - 1]
            x = a[k]
            i = min(int(x), L - 1)
            fa = x - i
            ti, tk = t[i], t[i + 1]
            mu = t[j + 1][j + 1] - t[j + 1][j]
            lo = (1.0 - fa) * ti[j] + fa * tk[j]
            hi = (1.0 - fa) * ti[j + 1] + fa * tk[j + 1]
            w = min(x - j, 1.0)
            if base_k != k:
                base_k, base = k, c[k] - (everett(t, x, b[k - 1]) if k else 0.0)
            yield s, e, j, 2.0 * (base + lo) - self.total, 2.0 * (hi - lo + w * mu), -2.0 * mu
            if k and e == b[k - 1]:
                k -= 1
            s = e
