"""A fast evaluator of the base device's phase part (the same Preisach model, not a new one).

``base.Hysteresis`` recomputes every cell's signed area at each call (a few
hundred microseconds); the simulator needs the phase at many instants inside
each reading window.  This class keeps the memory as the usual alternating
stack of dominant extremes and evaluates the phase through the Everett
function of the base device's own cell densities (uniform inside each cell,
diagonal cells triangles), so each move costs a few scalar look-ups.  It is
checked against ``base.Hysteresis`` in ``tests/test_rigtime_rt_c.py``.

Grid coordinates: ``c = (x - v_min) / h`` in ``[0, L]``; cell ``(i, j)`` has
up-threshold ``alpha`` in band ``i`` and down-threshold ``beta`` in band
``j <= i``.  A run starts in negative saturation (input at 0).
"""

from __future__ import annotations

import numpy as np


class FastPhase:
    def __init__(self, device) -> None:
        grid = device.grid
        self.L = int(device.levels)
        self.v_min = float(device.v_min_V)
        self.h = float(grid.step)
        D = np.asarray(grid.density_matrix(np.asarray(device.density_um, dtype=float)), dtype=float)
        C = np.zeros((self.L + 1, self.L + 1))
        C[1:, 1:] = np.cumsum(np.cumsum(D, axis=0), axis=1)
        self._D = D.tolist()
        rows = D.sum(axis=1)
        self._row_off = (rows - np.diag(D)).tolist()
        self._row_cum = np.concatenate([[0.0], np.cumsum(rows)]).tolist()
        self._C = C.tolist()
        self.total = float(np.sum(D))
        L = float(self.L)
        self._ext = [L, 0.0]
        self._done = [0.0, 0.0]
        self._x = 0.0

    # -- geometry -------------------------------------------------------
    def coord(self, v: float) -> float:
        c = (v - self.v_min) / self.h
        return 0.0 if c < 0.0 else (float(self.L) if c > self.L else c)

    def _H(self, a: float, b: float) -> float:
        """Mass of the hysterons with alpha <= a and beta <= b (coordinates)."""
        L, C, D = self.L, self._C, self._D
        i = int(a)
        if i >= L:
            i = L - 1
        fa = a - i
        j = int(b)
        if j >= L:
            j = L - 1
        fb = b - j
        tot = C[i][j]
        if j <= i:
            tot += fa * (C[i + 1][j] - C[i][j])
        else:
            tot += fa * (C[i + 1][i] - C[i][i]) + fa * fa * D[i][i]
        if j < i:
            djj = D[j][j]
            tot += fb * ((C[i][j + 1] - C[i][j]) - djj) + (2.0 * fb - fb * fb) * djj
            tot += fa * fb * D[i][j]
        elif j == i:
            m = fa if fa < fb else fb
            tot += (2.0 * fa * m - m * m) * D[i][i]
        return tot

    def _E(self, alpha: float, beta: float) -> float:
        """Everett function: mass of ``beta <= b <= a <= alpha`` (0 if alpha <= beta)."""
        if alpha <= beta:
            return 0.0
        i = int(alpha)
        if i >= self.L:
            i = self.L - 1
        fa = alpha - i
        return (self._row_cum[i] + fa * self._row_off[i] + fa * fa * self._D[i][i]) - self._H(alpha, beta)

    # -- memory ---------------------------------------------------------
    def _plus_mass(self) -> float:
        ext, x = self._ext, self._x
        n = len(ext)
        if n % 2 == 0:                      # ascending from the last minimum
            return self._done[-1] + self._E(x, ext[-1])
        return self._done[-1] + self._E(ext[-1], ext[-2]) - self._E(ext[-1], x)

    def value(self) -> float:
        return -self.total + 2.0 * self._plus_mass()

    def move_coord(self, y: float) -> None:
        ext, done = self._ext, self._done
        asc = len(ext) % 2 == 0
        if asc:
            if y < self._x:                 # reversal: the current input becomes a maximum
                ext.append(self._x)
                done.append(done[-1])
                asc = False
        else:
            if y > self._x:                 # reversal: the current input becomes a minimum
                ext.append(self._x)
                M, m_prev, m = ext[-2], ext[-3], ext[-1]
                done.append(done[-1] + self._E(M, m_prev) - self._E(M, m))
                asc = True
        self._x = y
        if asc:
            while len(ext) >= 4 and y >= ext[-2]:
                ext.pop(); ext.pop(); done.pop(); done.pop()
        else:
            while len(ext) >= 4 and y <= ext[-2]:
                ext.pop(); ext.pop(); done.pop(); done.pop()

    def corners_V(self) -> list[float]:
        """The memory's dominant extremes and the current input (V): where a branch may kink."""
        return [self.v_min + c * self.h for c in self._ext[2:] + [self._x]]

    def move(self, v: float) -> float:
        """Move the hysterons' input to ``v`` (V) and return the phase part (um)."""
        self.move_coord(self.coord(float(v)))
        return self.value()
