"""An exact, fast evaluator of the base device's Preisach phase (the same numbers as ``Hysteresis``).

``base.Hysteresis.move`` recomputes every cell's signed area at each call
(about 0.1-0.25 ms); a run that follows the film's temperature through its
transients needs thousands of moves, so this module evaluates the same sum in
O(1) per move.

The phase is ``sum_c density_c s_c`` with ``s_c = 2 plus_area_c / area_c - 1``,
i.e. ``-swing + 2 * integral of D over the +1 region`` where ``D`` is the
piecewise-constant density per unit area (``density_c / area_c``, zero above
the diagonal).  The +1 region is the staircase of the memory curve (same
update rule as ``identify.memory.MemoryCurve``, corners ``(a_k, b_k)``), so
the integral is ``sum_k C(a_k, b_k) - C(a_{k+1}, b_k)`` (``a_K = 0``) with
``C(alpha, beta)`` the integral of ``D`` over ``[0, alpha] x [0, beta]``;
``C`` is evaluated exactly from cumulative tables (bilinear in square cells,
quadratic in the diagonal triangles).  A prefix sum over the corners makes a
move cost only the terms of the corners it changes.
"""

from __future__ import annotations

import numpy as np

from identify.grid import WALL_TOLERANCE


class _Tables:
    """Cumulative integrals of one device's density (shared by all its ``FastPreisach``)."""

    def __init__(self, device) -> None:
        grid = device.grid
        L = grid.levels
        W = grid.density_matrix(np.asarray(device.density_um, dtype=float))  # [i, j], j <= i
        RC = np.zeros((L, L + 1))
        RC[:, 1:] = np.cumsum(W, axis=1)  # RC[i, j] = sum_{j' < j} W[i, j']
        T = W.sum(axis=1)
        ST = np.concatenate([[0.0], np.cumsum(T)])
        RCm = np.zeros((L, L + 1))
        Wm = np.zeros((L, L + 1))
        for i in range(L):
            RCm[i, :i] = RC[i, :i]
            Wm[i, :i] = W[i, :i]
        cumRC = np.zeros((L + 1, L + 1))
        cumW = np.zeros((L + 1, L + 1))
        cumRC[1:] = np.cumsum(RCm, axis=0)  # cumRC[i, j] = sum_{j < i' < i} RC[i', j]
        cumW[1:] = np.cumsum(Wm, axis=0)
        self.L = L
        self.v_min = float(grid.v_min)
        self.step = float(grid.step)
        self.swing = float(np.sum(device.density_um))
        self.W = W.tolist()
        self.RC = RC.tolist()
        self.ST = ST.tolist()
        self.cumRC = cumRC.tolist()
        self.cumW = cumW.tolist()

    def coordinate(self, v: float) -> float:
        """``Grid.coordinates`` for one input, in plain floats (same operations)."""
        x = (float(v) - self.v_min) / self.step
        x = min(max(x, 0.0), float(self.L))
        r = float(round(x))
        return r if abs(x - r) <= WALL_TOLERANCE else x

    def C(self, alpha: float, beta: float) -> float:
        """Integral of the density per unit area over ``[0, alpha] x [0, beta]`` (grid coordinates)."""
        if beta > alpha:
            beta = alpha
        if alpha <= 0.0 or beta <= 0.0:
            return 0.0
        L = self.L
        i = min(int(alpha), L)
        p = alpha - i
        j = min(int(beta), L)
        q = beta - j
        W, RC = self.W, self.RC
        if j < i:
            Wj = W[j][j]
            full = (self.ST[j] + RC[j][j] + Wj * (2.0 * q - q * q)
                    + self.cumRC[i][j] + q * self.cumW[i][j])
        else:
            full = self.ST[i]
        if i < L and p > 0.0:
            row, Wi = RC[i], W[i][i]
            if j < i:
                full += p * (row[j] + q * W[i][j])
            elif j > i:
                full += p * row[i] + Wi * p * p
            else:
                full += p * row[i] + 2.0 * Wi * (0.5 * p * p if p <= q else q * p - 0.5 * q * q)
        return full


class FastPreisach:
    """The film's memory in negative saturation; ``move(v)`` returns the phase part (um) as ``Hysteresis.move``."""

    __slots__ = ("_t", "_a", "_b", "_pre", "_plus", "position")

    def __init__(self, device=None, tables: _Tables | None = None) -> None:
        self._t = tables if tables is not None else _Tables(device)
        self._a: list[float] = []
        self._b: list[float] = []
        self._pre: list[float] = []
        self._plus = 0.0
        self.position = 0.0

    @property
    def swing(self) -> float:
        return self._t.swing

    def copy(self) -> "FastPreisach":
        other = FastPreisach(tables=self._t)
        other._a, other._b, other._pre = list(self._a), list(self._b), list(self._pre)
        other._plus, other.position = self._plus, self.position
        return other

    def value(self) -> float:
        return 2.0 * self._plus - self._t.swing

    def peek(self, v: float) -> float:
        return self.copy().move(v)

    def move(self, v: float) -> float:
        t = self._t
        x = t.coordinate(v)
        a, b, pre = self._a, self._b, self._pre
        if x > self.position:
            k = len(a)
            while k > 0 and a[k - 1] <= x:
                k -= 1
            del a[k:], b[k:], pre[k:]
            if k:
                last = pre[k - 1] + t.C(a[k - 1], b[k - 1]) - t.C(x, b[k - 1])
            else:
                last = 0.0
            a.append(x)
            b.append(x)
            pre.append(last)
            self._plus = last + t.C(x, x)
        elif x < self.position:
            k = 0
            while k < len(b) and b[k] < x:
                k += 1
            if k < len(b):
                del a[k + 1:], b[k + 1:], pre[k + 1:]
                b[k] = x
            if b and b[-1] <= 0.0:
                a.pop()
                b.pop()
                pre.pop()
            self._plus = (pre[-1] + t.C(a[-1], b[-1])) if a else 0.0
        self.position = x
        return 2.0 * self._plus - t.swing


def tables(device) -> _Tables:
    return _Tables(device)


__all__ = ["FastPreisach", "tables"]
