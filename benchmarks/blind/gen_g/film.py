"""The film's grains, cell by cell: geometry of the base device's Preisach cells and a sub-grain tracker.

The base device's ``density_um`` lists the cells row by row: row ``i`` (0 first) holds the hysterons
switching up in the band ``[L-1-i, L-i]`` of levels (the highest band first), and its ``L-i`` cells
run over the switching-down bands ``[j, j+1]``, ``j = 0 .. L-1-i``; the last cell of a row is the
triangle on the diagonal.  (Probed through the public ``Hysteresis`` in the tests.)

:class:`GrainTracker` follows a few sub-hysterons inside every cell, so that each cell's state (its
signed area) and the number of times its grains have been through the transition are known; the
accommodation mechanism re-weights cells with it.
"""

from __future__ import annotations

import functools

import numpy as np


@functools.lru_cache(maxsize=8)
def cell_bands(levels: int) -> tuple[np.ndarray, np.ndarray]:
    """(up band index, down band index) of every cell, in level units (band k is [k, k+1])."""
    up, down = [], []
    for i in range(levels):
        for j in range(levels - i):
            up.append(levels - 1 - i)
            down.append(j)
    return np.array(up), np.array(down)


def density_grid(device) -> np.ndarray:
    """The density as an (up band, down band) array, zero outside the Preisach triangle."""
    up, down = cell_bands(device.levels)
    g = np.zeros((device.levels, device.levels))
    g[up, down] = device.density_um
    return g


def slopes(device) -> tuple[float, float]:
    """(steepest slope of the major loop in um/V, the input in V where it is steepest).

    The major ascending branch rises by ``2 * row sum / band width`` over each up band, the
    descending branch by ``2 * column sum / band width`` over each down band.
    """
    g = density_grid(device)
    dv = (device.v_max_V - device.v_min_V) / device.levels
    rows, cols = g.sum(axis=1), g.sum(axis=0)
    k_up, k_dn = int(np.argmax(rows)), int(np.argmax(cols))
    s_up, s_dn = 2 * rows[k_up] / dv, 2 * cols[k_dn] / dv
    if s_up >= s_dn:
        return float(s_up), float(device.v_min_V + (k_up + 0.5) * dv)
    return float(s_dn), float(device.v_min_V + (k_dn + 0.5) * dv)


class GrainTracker:
    """Sub-hysterons (``m`` x ``m`` per square cell, the upper part on the diagonal) of every cell."""

    def __init__(self, device, m: int = 3) -> None:
        L = device.levels
        dv = (device.v_max_V - device.v_min_V) / L
        up, down = cell_bands(L)
        a_list, b_list, c_list = [], [], []
        offs = (np.arange(m) + 0.5) / m
        for c, (ku, kd) in enumerate(zip(up, down)):
            for p in offs:
                for q in offs:
                    if ku == kd and p <= q:
                        continue
                    a_list.append(device.v_min_V + (ku + p) * dv)
                    b_list.append(device.v_min_V + (kd + q) * dv)
                    c_list.append(c)
        self.alpha = np.array(a_list)
        self.beta = np.array(b_list)
        self.cell = np.array(c_list)
        self.n_cells = len(up)
        self.per_cell = np.bincount(self.cell, minlength=self.n_cells).astype(float)
        w = np.asarray(device.density_um, dtype=float)[self.cell] / self.per_cell[self.cell]
        self.weight = w / max(float(np.sum(w)), 1e-300)  # each sub-hysteron's share of the film
        self.ups = np.zeros(len(self.alpha))         # completed switchings to the metallic phase
        self.transformed = 0.0                        # total |change of the metallic fraction| (film)
        self.reset()

    def reset(self) -> None:
        """Negative saturation (a new run after a long rest at 0 V); the use counts are kept."""
        self.state = -np.ones(len(self.alpha))
        self.x = -np.inf

    def move(self, x: float) -> None:
        if x > self.x:
            flip = (self.alpha <= x) & (self.state < 0)
            self.state[flip] = 1.0
            self.ups[flip] += 1.0
        elif x < self.x:
            flip = (self.beta >= x) & (self.state > 0)
            self.state[flip] = -1.0
        else:
            return
        self.transformed += float(np.sum(self.weight[flip]))
        self.x = x

    def cell_state(self) -> np.ndarray:
        return np.bincount(self.cell, weights=self.state, minlength=self.n_cells) / self.per_cell

    def cell_cycles(self) -> np.ndarray:
        return np.bincount(self.cell, weights=self.ups, minlength=self.n_cells) / self.per_cell

    def film_cycles(self) -> float:
        """Full-film equivalent cycles: total transformed fraction over two (a cycle goes there and back)."""
        return 0.5 * self.transformed
