"""Settling time of a form: the worst set-point step over the device's range."""

from __future__ import annotations

import json
import math

import numpy as np
from scipy.optimize import brentq

from .thermal import Network, Segment

#: Bounds on the base devices' steady rise at full voltage (K): ~70 to ~100 K.  The settling
#: time takes the most pessimistic one for each temperature-dependent effect.
RISE_HI_K = 105.0
RISES_K = (65.0, 75.0, 85.0, 95.0, 105.0)

#: Envelope, over the base devices (``base.draw_device``, seeds 0-299, both major branches), of
#: the fraction of the film transforming within each 1 K bin of temperature rise (bins from 0 K),
#: widened by +-2 bins and by 25 %.  Bounds the latent heat a step can carry, device-free.
PHI_PER_K = np.array([
    0.0014, 0.0023, 0.0038, 0.0054, 0.0085, 0.0134, 0.0152, 0.0273, 0.0277, 0.0461, 0.0461,
    0.0677, 0.0677, 0.0816, 0.0864, 0.0956, 0.1492, 0.1492, 0.169, 0.1745, 0.1745, 0.1745,
    0.1745, 0.1745, 0.1705, 0.1595, 0.1698, 0.1797, 0.1797, 0.1797, 0.1797, 0.18, 0.18, 0.18,
    0.18, 0.18, 0.1794, 0.176, 0.1871, 0.1871, 0.1871, 0.1871, 0.1871, 0.1826, 0.1783, 0.176,
    0.1744, 0.1722, 0.1722, 0.1722, 0.1722, 0.1719, 0.1716, 0.1469, 0.1455, 0.1442, 0.1174,
    0.1163, 0.0987, 0.0651, 0.0635, 0.0531, 0.0373, 0.0298, 0.029, 0.0203, 0.0202, 0.0144,
    0.008, 0.0076, 0.0045, 0.0044, 0.0037, 0.0016, 0.0012, 0.0006, 0.0006, 0.0004, 0.0003,
    0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001,
    0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001, 0.0001,
    0.0001, 0.0001, 0.0001])


def latent_bound(T1: float, T2: float) -> float:
    """Largest secant ``d(phi)/dT`` (1/K) a step of the film between rises T1 and T2 (K) can have."""
    lo, hi = min(T1, T2), max(T1, T2)
    b0 = int(math.floor(lo))
    b1 = max(int(math.ceil(hi)), b0 + 1)
    bins = PHI_PER_K[min(b0, PHI_PER_K.size): min(b1, PHI_PER_K.size)]
    if bins.size == 0:
        return 0.0
    if hi - lo < 1.0:
        return float(bins.max())
    return float(min(1.0, bins.sum()) / (hi - lo))


_CACHE: dict = {}

_LEVELS = (0.0, 0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.0)
_SMALL = ((0.3, 0.33), (0.5, 0.53), (0.7, 0.73), (0.9, 0.93), (0.55, 0.6), (0.65, 0.7))


def _pairs():
    out = [(a, b) for a in _LEVELS for b in _LEVELS if a != b]
    for a, b in _SMALL:
        out += [(a, b), (b, a)]
    return out


def step_settling(net: Network, u1: float, u2: float, tolerance: float) -> float:
    """Settling time (s) of every output's equivalent voltage after a step u1 -> u2 from steady state.

    Voltages are fractions of the full range; the capacities are frozen pessimistically (the
    hottest plausible device for silicon's specific heat, the largest latent secant the step
    could carry on any base device).
    """
    T_dest = RISE_HI_K * u2 * u2 * net.gamma
    lat = np.zeros(net.M)
    if net.latent_K > 0.0:
        for R in RISES_K:
            for i in range(net.M):
                s = latent_bound(R * u1 * u1 * net.gain[i], R * u2 * u2 * net.gain[i])
                lat[i] = max(lat[i], min(net.latent_cap, net.latent_K * s))
    C = net.capacities(T_dest, lat)
    seg = Segment(net, C, u1 * u1 * net.gamma, u1, u2)
    g = net.gain
    step = abs(u2 - u1)
    bound = tolerance * step

    def excess(t: np.ndarray) -> np.ndarray:
        dev = seg.dev(np.atleast_1d(t))
        theta = np.maximum(u2 * u2 * g + dev, 0.0)
        x = np.sqrt(theta / g)
        err = np.abs(dev) / (g * (x + u2) + 1e-300)
        return err.max(axis=1) - bound

    # a horizon where even the slowest mode has decayed far below the bound
    lam_min = seg.slowest_rate()
    amp = float(np.abs(seg.z0).sum() * np.abs(seg.Ho).max() + np.abs(seg.rho).sum() * 1e3 + 1.0)
    lim = max(bound, 1e-300) ** 2 / amp
    horizon = (math.log(1.0 / lim) + 5.0) / lam_min
    t_lo = 1e-3 / seg.fastest_rate()
    t = np.concatenate([[0.0], np.geomspace(t_lo, horizon, 600)])
    e = excess(t)
    bad = np.nonzero(e > 0)[0]
    if bad.size == 0:
        return 0.0
    k = int(bad[-1])
    if k + 1 >= t.size:
        return float(t[-1])
    f = lambda s: float(excess(np.array([s]))[0])
    return float(brentq(f, t[k], t[k + 1], xtol=1e-12 * t[k + 1], rtol=1e-12))


def settling_time_s(form: dict, tolerance: float) -> float:
    """Longest time (s) after any set-point step within the device's range until the film's
    temperature (as an equivalent voltage) stays within ``tolerance`` (a fraction of the step)
    of its new steady state."""
    if form.get("kind") == "instant":
        return 0.0
    key = (json.dumps(form, sort_keys=True), float(tolerance))
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    net = Network(form)
    worst = 0.0
    for u1, u2 in _pairs():
        worst = max(worst, step_settling(net, u1, u2, float(tolerance)))
    if len(_CACHE) > 256:
        _CACHE.clear()
    _CACHE[key] = worst
    return worst
