"""A vectorised Everett-function evaluator of the base device's Preisach model.

The base device's :class:`~benchmarks.blind.base.Hysteresis` evaluates the phase
part with one dense sum per call (~0.15 ms).  The thermal simulator needs the
phase at many instants of many film patches, so this module evaluates the same
Preisach model through its Everett function: the cell weights are *measured from
the base device itself* (one probe per cell corner, through its public
``Hysteresis``), so no assumption about the ordering of ``density_um`` is made,
and each cell's density is uniform (squares off the diagonal, half-square
triangles on it), as base.py states.  ``tests/test_rigtime_rt_d.py`` checks it
against ``base.Hysteresis`` on random paths.

Coordinates: ``c = levels * (x - v_min) / (v_max - v_min)`` clamped to ``[0, levels]``.
A hysteron ``(alpha, beta)``, ``beta <= alpha``, switches up when the input rises
to ``alpha`` and down when it falls to ``beta``.
"""

from __future__ import annotations

import weakref

import numpy as np

_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


class Everett:
    """``W(a, b)``: the weight of the hysterons with ``b <= beta <= alpha <= a`` (um), exact."""

    def __init__(self, device) -> None:
        L = int(device.levels)
        self.L = L
        self.v_min = float(device.v_min_V)
        self.v_max = float(device.v_max_V)
        self.S = float(device.phase_swing_um)
        step = (self.v_max - self.v_min) / L
        # Corner probes: from negative saturation up to level a, then down to level b.
        corner = np.zeros((L + 1, L + 1))  # corner[a, b] = W(a, b), b <= a
        for a in range(1, L + 1):
            h = device.hysteresis()
            up = h.move(self.v_min + a * step)
            for b in range(a):
                corner[a, b] = 0.5 * (up - h.peek(self.v_min + b * step))
        q = np.zeros((L, L))  # square cells (i > j): alpha in [i, i+1], beta in [j, j+1]
        for i in range(1, L):
            j = np.arange(i)
            q[i, j] = corner[i + 1, j] - corner[i, j] - corner[i + 1, j + 1] + corner[i, j + 1]
        d = np.array([corner[k + 1, k] for k in range(L)])  # diagonal (triangle) cells
        self.q = q
        self.d = d
        self.corner = corner
        # prefix sums: row[i, j] = sum_{j' < j} q[i, j'];  col[i, j] = sum_{i' < i} q[i', j]
        self.row = np.concatenate([np.zeros((L, 1)), np.cumsum(q, axis=1)], axis=1)
        self.col = np.concatenate([np.zeros((1, L)), np.cumsum(q, axis=0)], axis=0)
        self._k = L / (self.v_max - self.v_min)
        self._rowdiag = self.row[np.arange(L), np.arange(L)]
        self._colnext = np.append(self.col[np.arange(1, L + 1), np.arange(L)][:-1], 0.0)
        self._colnext[L - 1] = self.col[L, L - 1]
        # python-list copies for the scalar path
        self._cl, self._rl, self._col_l = corner.tolist(), self.row.tolist(), self.col.tolist()
        self._ql, self._dl = q.tolist(), d.tolist()

    def W1(self, a: float, b: float) -> float:
        """Scalar ``W(a, b)``."""
        L = self.L
        ia = int(a)
        if ia > L - 1:
            ia = L - 1
        ib = int(b)
        if ib > L - 1:
            ib = L - 1
        if ia <= ib:
            d = a - b
            return d * d * self._dl[ia] if d > 0 else 0.0
        fa = a - ia
        gb = 1.0 - (b - ib)
        ib1 = ib + 1
        ra = self._rl[ia]
        return (self._cl[ia][ib1] + fa * (ra[ia] - ra[ib1]) + fa * fa * self._dl[ia]
                + fa * gb * self._ql[ia][ib] + gb * (self._col_l[ia][ib] - self._col_l[ib1][ib])
                + gb * gb * self._dl[ib])

    def coord(self, x):
        c = (np.asarray(x, dtype=float) - self.v_min) * self._k
        np.clip(c, 0.0, float(self.L), out=c)
        return c

    def W_up(self, a: np.ndarray, b: float) -> np.ndarray:
        """``W(a, b)`` for an array ``a`` (coordinates >= b) and a scalar ``b``."""
        L = self.L
        ib = min(int(b), L - 1)
        gb = 1.0 - (b - ib)
        ib1 = ib + 1
        P0 = self.corner[:L, ib1] + gb * (self.col[:L, ib] - self.col[ib1, ib]) + gb * gb * self.d[ib]
        P1 = self._rowdiag - self.row[:, ib1] + gb * self.q[:, ib]
        ia = np.minimum(a.astype(int), L - 1)
        fa = a - ia
        out = P0[ia] + fa * (P1[ia] + fa * self.d[ia])
        same = ia <= ib
        if same.any():
            dd = np.maximum(a - b, 0.0)
            out = np.where(same, dd * dd * self.d[ib], out)
        return out

    def W_down(self, a: float, b: np.ndarray) -> np.ndarray:
        """``W(a, b)`` for a scalar ``a`` and an array ``b`` (coordinates <= a)."""
        L = self.L
        ia = min(int(a), L - 1)
        fa = a - ia
        Q0 = self.corner[ia, 1:] + fa * (self._rowdiag[ia] - self.row[ia, 1:]) + fa * fa * self.d[ia]
        Q1 = fa * self.q[ia, :] + self.col[ia, :] - self._colnext
        ib = np.minimum(b.astype(int), L - 1)
        gb = 1.0 - (b - ib)
        out = Q0[ib] + gb * (Q1[ib] + gb * self.d[ib])
        same = ib >= ia
        if same.any():
            dd = np.maximum(a - b, 0.0)
            out = np.where(same, dd * dd * self.d[ia], out)
        return out

    def W(self, a, b):
        """Everett weight for coordinates ``a >= b`` (arrays broadcast)."""
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        L = self.L
        ia = np.minimum(np.floor(a).astype(int), L - 1)
        ib = np.minimum(np.floor(b).astype(int), L - 1)
        fa = a - ia
        gb = 1.0 - (b - ib)
        same = ia <= ib
        ib1 = np.minimum(ib + 1, L)
        full = self.corner[ia, ib1]
        colpart = fa * (self.row[ia, ia] - self.row[ia, ib1])
        rowpart = gb * (self.col[ia, ib] - self.col[ib1, ib])
        out = (full + colpart + fa * fa * self.d[ia] + fa * gb * self.q[ia, ib]
               + rowpart + gb * gb * self.d[ib])
        if same.any():
            out = np.where(same, np.square(np.maximum(a - b, 0.0)) * self.d[ia], out)
        return out


def everett(device) -> Everett:
    e = _CACHE.get(device)
    if e is None:
        e = Everett(device)
        _CACHE[device] = e
    return e


class Memory:
    """The film's Preisach memory as a stack of turning points (coordinate, phase)."""

    __slots__ = ("ev", "xs", "ps", "xc", "pc")

    def __init__(self, ev: Everett) -> None:
        self.ev = ev
        L, S = float(ev.L), ev.S
        # negative saturation: came down from +sat (L) to -sat (0)
        self.xs = [L, 0.0]
        self.ps = [S, -S]
        self.xc = 0.0
        self.pc = -S

    def copy(self) -> "Memory":
        m = Memory.__new__(Memory)
        m.ev, m.xs, m.ps, m.xc, m.pc = self.ev, list(self.xs), list(self.ps), self.xc, self.pc
        return m

    def peek(self, x: float) -> float:
        """The phase if the input moved to ``x`` (V) now; the memory is left as it is."""
        ev = self.ev
        c = (float(x) - ev.v_min) * ev._k
        c = 0.0 if c < 0.0 else (float(ev.L) if c > ev.L else c)
        if c == self.xc:
            return self.pc
        d = 1.0 if c > self.xc else -1.0
        xs, ps = self.xs, self.ps
        top = len(xs) - 1  # index of the branch origin
        cur = self.xc - xs[top]
        if cur != 0.0 and (cur > 0) != (d > 0):
            ox, op, prev = self.xc, self.pc, top  # reversal: the current point becomes the origin
        else:
            ox, op, prev = xs[top], ps[top], top - 1
        while True:
            B = xs[prev]
            if (d > 0 and c >= B) or (d < 0 and c <= B):
                if prev <= 1:
                    return ps[prev]
                ox, op, prev = xs[prev - 1], ps[prev - 1], prev - 2
                continue
            break
        return op + 2.0 * ev.W1(c, ox) if d > 0 else op - 2.0 * ev.W1(ox, c)

    def trace(self, x_V: np.ndarray) -> np.ndarray:
        """Move the input along ``x_V`` (V, in order) and return the phase (um) at each point."""
        c = self.ev.coord(x_V)
        out = np.empty(c.shape)
        n = c.size
        if n == 0:
            return out
        # split into monotone runs (still points join the run they sit in)
        dif = np.empty(n)
        dif[0] = c[0] - self.xc
        np.subtract(c[1:], c[:-1], out=dif[1:])
        up, down = bool((dif >= 0.0).all()), bool((dif <= 0.0).all())
        if up and down:
            out[:] = self.pc
            return out
        if up or down:
            out[:] = self._run(c, 1.0 if up else -1.0)
            return out
        sgn = np.sign(dif)
        nz = np.flatnonzero(sgn)
        signs = sgn[nz]
        change = np.flatnonzero(signs[1:] != signs[:-1]) + 1
        starts = [0] + nz[change].tolist() + [n]
        dirs = [signs[0]] + signs[change].tolist()
        for k in range(len(dirs)):
            out[starts[k]:starts[k + 1]] = self._run(c[starts[k]:starts[k + 1]], dirs[k])
        return out

    def _run(self, c: np.ndarray, d: float) -> np.ndarray:
        ev = self.ev
        xs, ps = self.xs, self.ps
        cur = self.xc - xs[-1]
        if cur != 0.0 and (cur > 0) != (d > 0):
            xs.append(self.xc)
            ps.append(self.pc)
        out = np.empty(c.shape)
        i, n = 0, c.size
        while i < n:
            B = xs[-2]
            if d > 0:
                k = i + int(np.searchsorted(c[i:], B, side="left"))
                if k == i + 1:
                    out[i] = ps[-1] + 2.0 * ev.W1(float(c[i]), xs[-1])
                elif k > i:
                    out[i:k] = ps[-1] + 2.0 * ev.W_up(c[i:k], xs[-1])
            else:
                k = i + int(np.searchsorted(-c[i:], -B, side="left"))
                if k == i + 1:
                    out[i] = ps[-1] - 2.0 * ev.W1(xs[-1], float(c[i]))
                elif k > i:
                    out[i:k] = ps[-1] - 2.0 * ev.W_down(xs[-1], c[i:k])
            if k >= n:
                break
            if len(xs) <= 3:
                # xs[-2] is a sentinel: the input reached saturation
                sat_x, sat_p = xs[-2], ps[-2]
                other_x, other_p = (0.0, -ev.S) if sat_x > 0 else (float(ev.L), ev.S)
                xs[:] = [other_x, sat_x]
                ps[:] = [other_p, sat_p]
                out[k:] = sat_p
                self.xc, self.pc = float(c[-1]), sat_p
                return out
            del xs[-2:]
            del ps[-2:]
            i = k
        self.xc, self.pc = float(c[-1]), float(out[-1])
        return out
