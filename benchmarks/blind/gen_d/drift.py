"""Slow lab disturbances: the family every drift (baseline, gain, ambient) is drawn from.

A drift's *form* says which disturbances are present and their character
(HVAC period and waveform, warm-up time, 1/f exponent, step rate, smoothing);
its *realisation* (phases, jitter, step times and sizes, the wander's
components) comes from the session's seed.  The path is in nominal units
(each component about 1 at its nominal amplitude), starts at 0 at the
session's start, is continuous across the gap between runs (so each run sees
a different piece of it) and is scaled by the caller.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

COMPONENTS = ("hvac", "warmup", "wander", "steps", "trend")
WAVEFORMS = ("sine", "triangle", "sawtooth", "bangbang")

#: Time step of the tabulated path (s); paths are interpolated linearly in between.
GRID_S = 2.0


def draw(rng: np.random.Generator, smoothing_s: tuple[float, float]) -> dict:
    """A random drift form: a mixture of lab disturbances, ``smoothing_s`` the range of its low-pass."""
    present = [c for c in COMPONENTS if rng.random() < 0.5]
    if not present:
        present = [COMPONENTS[int(rng.integers(len(COMPONENTS)))]]
    weights = rng.dirichlet(np.full(len(present), 1.5))
    form: dict = {"smoothing_s": float(np.exp(rng.uniform(*np.log(smoothing_s)))), "components": {}}
    for name, w in zip(present, weights):
        comp: dict = {"weight": float(w)}
        if name == "hvac":
            comp.update(period_s=float(rng.uniform(600.0, 1800.0)),
                        waveform=str(rng.choice(WAVEFORMS)), duty=float(rng.uniform(0.25, 0.75)),
                        jitter=float(rng.uniform(0.02, 0.15)), sign=float(rng.choice([-1.0, 1.0])))
        elif name == "warmup":
            comp.update(tau_s=float(np.exp(rng.uniform(np.log(600.0), np.log(7200.0)))),
                        sign=float(rng.choice([-1.0, 1.0])))
        elif name == "wander":
            comp.update(alpha=float(rng.uniform(1.0, 2.0)))
        elif name == "steps":
            comp.update(rate_per_h=float(rng.uniform(0.3, 1.5)),
                        rise_s=float(np.exp(rng.uniform(np.log(5.0), np.log(120.0)))))
        elif name == "trend":
            comp.update(sign=float(rng.choice([-1.0, 1.0])))
        form["components"][name] = comp
    return form


def _hvac(c: dict, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    period = c["period_s"]
    # Cycle-to-cycle variation of the thermostat's period: a slow random modulation of its rate.
    freqs = rng.uniform(0.2, 1.0, 4) / period
    mod = np.zeros_like(t)
    for f in freqs:
        mod += np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    rate = (1.0 + c["jitter"] * mod / 2.0) / period
    phase = rng.uniform(0.0, 1.0) + np.concatenate([[0.0], np.cumsum(rate[:-1] * np.diff(t))])
    frac = np.mod(phase, 1.0)
    duty = c["duty"]
    wave = c["waveform"]
    if wave == "sine":
        y = np.sin(2 * np.pi * frac)
    elif wave == "triangle":
        y = 2.0 * np.abs(2.0 * frac - 1.0) - 1.0
    elif wave == "sawtooth":
        y = np.where(frac < duty, frac / duty, (1.0 - frac) / (1.0 - duty)) * 2.0 - 1.0
    else:  # bang-bang heating: an on/off square wave seen through a first-order room response
        square = np.where(frac < duty, 1.0, -1.0)
        tau = period * rng.uniform(0.08, 0.3)
        alpha = 1.0 - np.exp(-GRID_S / tau)
        y, _ = lfilter([alpha], [1.0, alpha - 1.0], square, zi=[square[0] * (1.0 - alpha)])
        span = np.ptp(y)
        y = (y - y.mean()) * (2.0 / span if span > 0 else 1.0)
    return c["sign"] * y


def _wander(c: dict, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """1/f^alpha wander from 1/(8 h) to 1/(90 s): random-phase components with Rayleigh amplitudes."""
    m = 48
    f = np.exp(np.linspace(np.log(1.0 / 28_800.0), np.log(1.0 / 90.0), m))
    f = f * np.exp(rng.uniform(-0.05, 0.05, m))
    psd = f ** (-c["alpha"])
    amp = np.sqrt(psd / psd.sum()) * rng.rayleigh(1.0, m)
    ph = rng.uniform(0, 2 * np.pi, m)
    return np.sin(np.outer(t, 2 * np.pi * f) + ph) @ amp


def _steps(c: dict, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    span = float(t[-1] - t[0])
    count = int(rng.poisson(c["rate_per_h"] * span / 3600.0))
    when = np.sort(rng.uniform(t[0], t[-1], count))
    size = rng.normal(0.0, 0.7, count)
    y = np.zeros_like(t)
    for tk, sk in zip(when, size):
        dt = t - tk
        y += np.where(dt > 0, sk * (1.0 - np.exp(-np.maximum(dt, 0.0) / c["rise_s"])), 0.0)
    return y


def path(form: dict, rng: np.random.Generator, end_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The drift's realisation on a grid ``(t, y)`` covering ``[0, end_s]``, ``y[0] = 0``."""
    t = np.arange(0.0, end_s + 2 * GRID_S, GRID_S)
    total = np.zeros_like(t)
    comps = form["components"]
    # Draw every component's realisation in a fixed order, present or not, so that each
    # component's realisation does not depend on the others.
    for name in COMPONENTS:
        sub = np.random.default_rng(rng.integers(0, 2**63))
        if name not in comps:
            continue
        c = comps[name]
        if name == "hvac":
            y = _hvac(c, t, sub)
        elif name == "warmup":
            y = c["sign"] * sub.lognormal(0.0, 0.3) * (1.0 - np.exp(-t / c["tau_s"]))
        elif name == "wander":
            y = _wander(c, t, sub)
        elif name == "steps":
            y = _steps(c, t, sub)
        else:  # a steady trend of the day: about 1 nominal unit per two hours
            y = c["sign"] * sub.uniform(0.4, 1.2) * t / 7200.0
        total += c["weight"] * y
    alpha = 1.0 - np.exp(-GRID_S / form["smoothing_s"])
    smooth, _ = lfilter([alpha], [1.0, alpha - 1.0], total, zi=[total[0] * (1.0 - alpha)])
    return t, smooth - smooth[0]
