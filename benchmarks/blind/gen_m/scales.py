"""Device scales the mechanisms are sized against (computed once per device from its major loop).

Units: um, K, V.  Everything here is a property of the clean device, never of
the effects, so a mechanism's size at strength 1 is fixed by its form and the
device alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_CACHE: list[tuple[object, "DeviceScales"]] = []


@dataclass(frozen=True)
class DeviceScales:
    swing_um: float  # max - min of the clean output over the major loop (um)
    u_min_um: float
    u_max_um: float
    u_abs_max_um: float  # largest |output| over the major loop (um, from the sensor's zero)
    phase_swing_um: float  # S: the phase part runs from -S to +S (um)
    rise_max_K: float  # steady rise at v_max (K)
    rise_mid_K: float  # middle of the transition (heating and cooling), as a rise above ambient (K)
    slope_per_K: float  # steepest |d(phase)/d(rise)| / S on the major loop (1/K)


def scales(device) -> DeviceScales:
    """The scales of ``device`` (cached by identity)."""
    for dev, sc in _CACHE:
        if dev is device:
            return sc
    sc = _compute(device)
    _CACHE.append((device, sc))
    del _CACHE[:-8]
    return sc


def _compute(device) -> DeviceScales:
    v_up = np.linspace(device.v_min_V, device.v_max_V, 241)
    v = np.concatenate([v_up, v_up[::-1][1:]])
    h = device.hysteresis()
    phase = np.array([h.move(x) for x in v])
    u = device.bias_um + device.thermal_um_per_V * v + phase
    s = device.phase_swing_um
    rise = device.kelvin_per_V2 * v ** 2
    dr = np.diff(rise)
    ok = np.abs(dr) > 1e-9
    slope = float(np.max(np.abs(np.diff(phase)[ok] / dr[ok]))) / max(s, 1e-12)
    mid = 0.5 * (device.transition_heating_C + device.transition_cooling_C) - device.ambient_C
    return DeviceScales(
        swing_um=float(u.max() - u.min()), u_min_um=float(u.min()), u_max_um=float(u.max()),
        u_abs_max_um=float(np.max(np.abs(u))), phase_swing_um=float(s),
        rise_max_K=float(device.kelvin_per_V2 * device.v_max_V ** 2), rise_mid_K=float(mid),
        slope_per_K=max(slope, 1e-6),
    )
