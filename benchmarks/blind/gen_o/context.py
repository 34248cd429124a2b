"""Per-device reference quantities: output swing, major loop, the Preisach cells' layout.

Everything here is computed from the clean device through ``base``'s public
interface only (``hysteresis()``, ``output``, ``density_um``), and cached per
device object.
"""

from __future__ import annotations

import dataclasses
import weakref

import numpy as np

from ..base import BaseDevice

_CTX: "weakref.WeakKeyDictionary[BaseDevice, DeviceContext]" = weakref.WeakKeyDictionary()
_LAYOUT: dict = {}


def walls(device: BaseDevice) -> np.ndarray:
    """The grid's ``levels + 1`` walls (V)."""
    L = device.levels
    return device.v_min_V + (device.v_max_V - device.v_min_V) * np.arange(L + 1) / L


def cell_layout(device: BaseDevice) -> np.ndarray:
    """``(levels, levels)`` int array: index of the cell (alpha cell a, beta cell b) in ``density_um``, -1 if b > a.

    Found by probing a device whose cell weights are their own index + 1: after
    rising to wall a and falling to wall b (from negative saturation) the
    positive region holds exactly the cells (i <= a, j <= b); a mixed
    difference of four such states isolates one cell.
    """
    key = (device.levels, device.v_min_V, device.v_max_V)
    if key in _LAYOUT:
        return _LAYOUT[key]
    L = device.levels
    n = L * (L + 1) // 2
    code = np.arange(1, n + 1, dtype=float)
    probe = dataclasses.replace(device, density_um=code)
    w = walls(device)
    total = code.sum()
    G = np.zeros((L + 1, L + 1))
    for a in range(1, L + 1):
        h = probe.hysteresis()
        G[a, a:] = (h.move(w[a]) + total) / 2
        for b in range(a - 1, 0, -1):
            G[a, b] = (h.move(w[b]) + total) / 2
    W = G[1:, 1:] - G[:-1, 1:] - G[1:, :-1] + G[:-1, :-1]
    layout = -np.ones((L, L), dtype=int)
    for a in range(L):
        for b in range(a + 1):
            layout[a, b] = int(round(W[a, b])) - 1
    seen = np.sort(layout[layout >= 0])
    if not np.array_equal(seen, np.arange(n)):
        raise RuntimeError("could not map the Preisach cells of the base device")
    _LAYOUT[key] = layout
    return layout


class DeviceContext:
    """Reference quantities of one clean device."""

    def __init__(self, device: BaseDevice):
        self.device = device
        w = walls(device)
        self.major_v = np.concatenate([w[1:], w[-2::-1]])  # up to v_max then back to v_min
        h = device.hysteresis()
        p0 = h.value()
        ph = np.array([h.move(v) for v in self.major_v])
        self.major_phase = ph
        u = np.array([device.output(p, v) for p, v in zip(ph, self.major_v)])
        u = np.concatenate([[device.output(p0, device.v_min_V)], u])
        self.u_lo, self.u_hi = float(u.min()), float(u.max())
        self.swing_um = self.u_hi - self.u_lo
        self.u_rms = float(np.sqrt(np.mean(u ** 2)))
        dv = np.diff(np.concatenate([[device.v_min_V], self.major_v]))
        dp = np.diff(np.concatenate([[p0], ph]))
        self.phase_slope_max = float(np.max(np.abs(dp) / np.maximum(np.abs(dv), 1e-12)))
        sw = device.phase_swing_um
        self.phase_swing_um = sw
        # equivalent voltages of the transition (heating / cooling midpoints)
        self.v_heat = float(device.equivalent_voltage(device.transition_heating_C - device.ambient_C))
        self.v_cool = float(device.equivalent_voltage(device.transition_cooling_C - device.ambient_C))
        self.v_mid = float(np.clip(0.5 * (self.v_heat + self.v_cool), 0.1 * device.v_max_V, 0.95 * device.v_max_V))
        self.width_C = float(device.transition_width_C)

    def major_loop(self, dev: BaseDevice) -> np.ndarray:
        """The phase part of ``dev`` (same grid) along the major loop."""
        h = dev.hysteresis()
        return np.array([h.move(v) for v in self.major_v])


def context(device: BaseDevice) -> DeviceContext:
    ctx = _CTX.get(device)
    if ctx is None:
        ctx = DeviceContext(device)
        _CTX[device] = ctx
    return ctx


__all__ = ["DeviceContext", "cell_layout", "context", "walls"]
