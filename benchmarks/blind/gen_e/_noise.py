"""Slow stochastic and deterministic drift paths over a session (unit scale; the caller scales them).

All paths are generated on a uniform grid of session time (``DT`` s) from a dedicated random stream and
interpolated at the reading times, so a realisation depends only on (seed, mechanism, form, schedule
durations): never on the strength nor on the other mechanisms present.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

DT = 5.0


def grid(t_end: float) -> np.ndarray:
    return np.arange(0.0, float(t_end) + 2 * DT, DT)


def ou(rng: np.random.Generator, t: np.ndarray, tau: float) -> np.ndarray:
    """Ornstein-Uhlenbeck path with unit stationary std (exact AR(1) discretisation)."""
    a = np.exp(-DT / tau)
    w = rng.standard_normal(t.size)
    w[0] = w[0] / np.sqrt(1.0 - a * a)          # stationary start
    return lfilter([np.sqrt(1.0 - a * a)], [1.0, -a], w)


def flicker(rng: np.random.Generator, t: np.ndarray, alpha: float) -> np.ndarray:
    """1/f^alpha noise by spectral synthesis (random amplitudes and phases), unit std over the session."""
    n = int(2 ** np.ceil(np.log2(2 * t.size)))
    f = np.fft.rfftfreq(n, DT)
    amp = np.zeros_like(f)
    amp[1:] = f[1:] ** (-alpha / 2.0)
    spec = amp * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    x = np.fft.irfft(spec, n)[: t.size]
    x = x - x.mean()
    s = x.std()
    return x / s if s > 0 else x


def hvac(rng: np.random.Generator, t: np.ndarray, period: float, shape: str, duty: float) -> np.ndarray:
    """Thermostat cycling of the room: a periodic wave (unit rms-ish) with a random phase and jittered period."""
    jitter = 1.0 + 0.05 * ou(rng, t, 3.0 * period)           # the cycle wanders a little
    phase = rng.uniform(0.0, 1.0) + np.cumsum(jitter) * DT / period
    ph = phase % 1.0
    if shape == "sine":
        x = np.sin(2 * np.pi * ph)
    elif shape == "triangle":
        x = np.where(ph < duty, ph / duty, (1.0 - ph) / (1.0 - duty)) * 2.0 - 1.0
    else:  # sawtooth: slow warming, quick drop when the cooling kicks in
        x = np.where(ph < 0.9, ph / 0.9, (1.0 - ph) / 0.1) * 2.0 - 1.0
    x = x - x.mean()
    return x / max(x.std(), 1e-12)


def trend(t: np.ndarray, sign: int, curvature: float) -> np.ndarray:
    """A slow trend over the session, (-1 .. 1) over its span, slightly curved."""
    s = t / max(t[-1], 1.0)
    x = s + curvature * (s * s - s)
    return sign * (2.0 * x - 1.0) * np.sqrt(3.0) / 2.0


def diurnal(t: np.ndarray, phase: float) -> np.ndarray:
    return np.sqrt(2.0) * np.sin(2 * np.pi * t / 86400.0 + phase)


def mode_hops(rng: np.random.Generator, t: np.ndarray, rate_per_h: float, smoothing: float) -> np.ndarray:
    """Laser mode hops: small power jumps at Poisson times, each settling with ``smoothing`` s."""
    span = t[-1]
    count = rng.poisson(rate_per_h * span / 3600.0)
    times = np.sort(rng.uniform(0.0, span, count))
    jumps = rng.standard_normal(count)
    x = np.zeros_like(t)
    for tk, jk in zip(times, jumps):
        x += jk * -np.expm1(-np.maximum(t - tk, 0.0) / smoothing)
    return x / np.sqrt(max(rate_per_h * span / 3600.0, 1.0))


def tec_cycle(rng: np.random.Generator, t: np.ndarray, period: float) -> np.ndarray:
    """Laser diode TEC limit cycle: a slightly anharmonic oscillation."""
    ph = rng.uniform(0, 2 * np.pi)
    h2 = rng.uniform(-0.3, 0.3)
    x = np.sin(2 * np.pi * t / period + ph) + h2 * np.sin(4 * np.pi * t / period + 2 * ph)
    return x / np.sqrt((1 + h2 * h2) / 2.0)


def composite(rng: np.random.Generator, comps: list[dict], t: np.ndarray, run_starts: list[float]) -> np.ndarray:
    """Weighted sum of the form's components on grid ``t`` (session time); ``run_starts`` for per-run parts."""
    x = np.zeros_like(t)
    for c in comps:
        k, w = c["kind"], float(c["weight"])
        if k == "ou":
            y = ou(rng, t, float(c["tau_s"]))
        elif k == "flicker":
            y = flicker(rng, t, float(c["alpha"]))
        elif k == "hvac":
            y = hvac(rng, t, float(c["period_s"]), c["shape"], float(c["duty"]))
        elif k == "trend":
            y = trend(t, int(c["sign"]), float(c["curvature"]))
        elif k == "diurnal":
            y = diurnal(t, float(c["phase"]))
        elif k == "mode_hops":
            y = mode_hops(rng, t, float(c["rate_per_h"]), float(c["smoothing_s"]))
        elif k == "tec_cycle":
            y = tec_cycle(rng, t, float(c["period_s"]))
        elif k == "warmup":
            tau = float(c["tau_s"])
            y = np.zeros_like(t)
            starts = run_starts if c.get("per_run", False) else run_starts[:1]
            for i, t0 in enumerate(starts):
                a = rng.uniform(0.6, 1.4) if i == 0 else rng.uniform(0.15, 0.8)
                y += np.where(t >= t0, a * np.exp(-(t - t0) / tau), 0.0)
            y = 2.0 * c["sign"] * y
        elif k == "log_settling":
            tau = float(c["tau_s"])
            y = np.zeros_like(t)
            for i, t0 in enumerate(run_starts):
                a = rng.uniform(0.6, 1.4) if i == 0 else rng.uniform(0.2, 1.0)
                y += np.where(t >= t0, a * np.log1p(np.maximum(t - t0, 0.0) / tau), 0.0)
            y = c["sign"] * y / np.log1p(4 * 3600.0 / tau)
        else:
            raise ValueError(f"unknown drift component {k!r}")
        x += w * y
    return x


def lowpass(x: np.ndarray, tau: float) -> np.ndarray:
    """First-order low-pass (a package's thermal mass) on the grid, starting in equilibrium."""
    a = np.exp(-DT / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y
