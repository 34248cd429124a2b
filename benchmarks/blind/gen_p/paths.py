"""Random streams and the slow drifts' realisations.

Every run draws from streams of its own, keyed by ``(seed, run index, purpose)``: the timing of
the logger, the measurement noise, and one stream per drifting mechanism.  A drift's stream always
draws the same numbers in the same order (fixed-size arrays, whatever the form), so its
realisation depends only on the seed, the run, the run's duration and the form -- never on the
strength nor on the other mechanisms present; the strength only scales it afterwards.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

_ROOT = 7_040_219  # this generator's own root, distinct from base.py's

TAGS = dict(timing=1, noise=2, baseline_drift=3, ambient_drift=4, gain_drift=5)

#: Time step (s) of the grid on which the slow drifts are built, then interpolated.
DT_GRID = 10.0
_ROWS = 6
_EVENTS = 64


def stream(seed: int, run: int, purpose: str) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([_ROOT, int(seed), int(run), TAGS[purpose]]))


def ou(z: np.ndarray, dt: float, tau: float, stationary: bool = True) -> np.ndarray:
    """Unit-variance Ornstein-Uhlenbeck path on a uniform grid, driven by the normals ``z``."""
    a = float(np.exp(-dt / tau))
    b = float(np.sqrt(max(1.0 - a * a, 0.0)))
    x0 = float(z[0]) if stationary else 0.0
    out = np.empty_like(z)
    out[0] = x0
    if len(z) > 1:
        out[1:], _ = lfilter([b], [1.0, -a], z[1:], zi=[a * x0])
    return out


def lowpass(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """First-order low-pass on a uniform grid, starting in steady state."""
    a = float(np.exp(-dt / tau))
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * float(x[0])])
    return y


class Draws:
    """The fixed set of random numbers one drifting mechanism draws for one run."""

    def __init__(self, seed: int, run: int, purpose: str, n_grid: int) -> None:
        rng = stream(seed, run, purpose)
        self.z = rng.standard_normal((_ROWS, n_grid))
        self.n = rng.standard_normal(16)
        self.u = rng.random(16)
        self.gaps = rng.exponential(1.0, _EVENTS)
        self.sizes = rng.standard_normal(_EVENTS)
        self.signs_u = rng.random(_EVENTS)


def _events(t: np.ndarray, d: Draws, rate_per_h: float) -> np.ndarray:
    return np.cumsum(d.gaps) / (rate_per_h / 3600.0)


def unit_path(form: dict, t: np.ndarray, d: Draws) -> np.ndarray:
    """A drift's realisation (order 1 in size) on the uniform grid ``t`` (s, from the run's start)."""
    kind = form["kind"]
    dt = DT_GRID
    wander = float(form.get("wander", 0.0)) * ou(d.z[5], dt, float(form.get("wander_tau_s", 3600.0)))
    if kind == "ou":
        return ou(d.z[0], dt, form["tau_s"])
    if kind == "pink":
        taus = np.geomspace(form["tau_lo_s"], form["tau_hi_s"], 5)
        var = np.power(taus, form["gamma"])
        var /= var.sum()
        return sum(np.sqrt(v) * ou(d.z[k], dt, tk) for k, (v, tk) in enumerate(zip(var, taus)))
    if kind == "warmup":
        amp = np.exp(0.3 * d.n[0])
        tau = form["tau_s"] * np.exp(0.2 * d.n[1])
        return form["sign"] * amp * -np.expm1(-t / tau) + wander
    if kind == "settling":
        tau = form["tau_s"] * np.exp(0.2 * d.n[1])
        base = form["sign"] * np.exp(0.3 * d.n[0]) * np.log1p(t / tau) / np.log1p(10800.0 / tau)
        times = _events(t, d, form["slip_rate_per_h"])
        slips = np.zeros_like(t)
        for ti, size in zip(times[times < t[-1]], d.sizes):
            after = t > ti
            slips[after] += form["slip_rel"] * size * -np.expm1(-(t[after] - ti) / form["slip_tau_s"])
        return base + slips + wander
    if kind == "hvac":
        period = form["period_s"] * np.exp(0.05 * d.n[2])
        duty = form["duty"]
        frac = np.mod(t / period + d.u[0], 1.0)
        tri = np.where(frac < duty, -1.0 + 2.0 * frac / duty, 1.0 - 2.0 * (frac - duty) / (1.0 - duty))
        tau = form["tau_filter_s"]
        atten = 1.0 / np.sqrt(1.0 + (2.0 * np.pi * tau / period) ** 2)
        return lowpass(tri, dt, tau) / atten + wander
    if kind == "periodic":
        period = form["period_s"] * np.exp(0.05 * d.n[2])
        return np.sin(2.0 * np.pi * (t / period + d.u[0])) + wander
    if kind == "trend":
        return d.n[3] * t / 10800.0 + wander
    if kind == "events":
        times = _events(t, d, form["rate_per_h"])
        out = np.zeros_like(t)
        rise, decay = form["rise_s"], form["decay_s"]
        for ti, size, su in zip(times[times < t[-1]], d.sizes, d.signs_u):
            after = t > ti
            s = t[after] - ti
            sign = 1.0 if su < form["p_warm"] else -1.0
            out[after] += sign * (0.5 + abs(size)) * -np.expm1(-s / rise) * np.exp(-s / decay)
        return out + wander
    raise ValueError(kind)


def realise(form: dict, seed: int, run: int, purpose: str, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """The grid (s) and the unit realisation of a drift for one run of duration ``t_end`` (s)."""
    n = int(np.ceil(t_end / DT_GRID)) + 2
    t = np.arange(n) * DT_GRID
    d = Draws(seed, run, purpose, n)
    return t, unit_path(form, t, d)
