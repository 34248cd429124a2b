"""Realisations of slow wandering paths (PSD zero, PSD gain, room temperature) over a session.

A path is generated on a regular grid of session time (every ``GRID_S`` seconds, through
the runs and the gaps between them), from a random generator drawn from the seed and the
mechanism's name only, then normalised: it starts at 0 at the session's start and its
largest peak-to-peak excursion within one run is 1.  The strength scales it afterwards,
so the realisation never depends on the strength nor on the other mechanisms present.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

GRID_S = 5.0


def lowpass(x: np.ndarray, tau_s: float, dt: float = GRID_S, x0: float = 0.0) -> np.ndarray:
    """First-order low-pass (exact for a piecewise-constant input on the grid), starting at ``x0``."""
    a = float(np.exp(-dt / max(tau_s, 1e-9)))
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x0])
    return y


def _ou(rng: np.random.Generator, n: int, corr_s: float, dt: float = GRID_S) -> np.ndarray:
    phi = float(np.exp(-dt / corr_s))
    xi = rng.standard_normal(n)
    x0 = float(rng.standard_normal())
    y, _ = lfilter([np.sqrt(1.0 - phi * phi)], [1.0, -phi], xi, zi=[phi * x0])
    return y


def normalise(t: np.ndarray, y: np.ndarray, runs: list[tuple[float, float]]) -> np.ndarray:
    y = y - y[0]
    p2p = 0.0
    for start, end in runs:
        sel = (t >= start) & (t <= end)
        if np.count_nonzero(sel) > 1:
            p2p = max(p2p, float(np.ptp(y[sel])))
    return y / p2p if p2p > 1e-12 else y


def _component(form: dict, rng: np.random.Generator, t: np.ndarray,
               runs: list[tuple[float, float]]) -> np.ndarray:
    kind = form["kind"]
    n = t.size
    span = max(float(t[-1]), GRID_S)
    if kind == "random_walk":
        walk = np.cumsum(rng.standard_normal(n)) * np.sqrt(GRID_S)
        return lowpass(walk, form["smooth_s"])
    if kind == "ou":
        return _ou(rng, n, form["corr_s"])
    if kind == "warmup":
        drive = np.zeros(n)
        for start, end in runs:
            amp = float(rng.uniform(0.4, 1.0))
            drive[(t >= start) & (t <= end)] = form["sign"] * amp
        warm = lowpass(drive, form["tau_s"])
        walk = lowpass(np.cumsum(rng.standard_normal(n)) * np.sqrt(GRID_S), 300.0)
        walk = walk / max(float(np.ptp(walk)), 1e-12)
        warm = warm / max(float(np.ptp(warm)), 1e-12)
        return warm + form["wander"] * walk
    if kind == "periodic":
        period = form["period_s"]
        mod = _ou(rng, n, 3.0 * period)
        phase = 2 * np.pi * np.cumsum(GRID_S / (period * (1.0 + form["period_jitter"] * np.tanh(mod))))
        phase += float(rng.uniform(0, 2 * np.pi))
        theta = float(rng.uniform(0, 2 * np.pi))
        y = np.sin(phase) + form["harmonic"] * np.sin(2 * phase + theta)
        return y + form["trend"] * float(rng.standard_normal()) * 2.0 * t / span
    if kind == "trend":
        c = rng.standard_normal(form["degree"])
        s = t / span
        return sum(c[k] * s ** (k + 1) for k in range(form["degree"]))
    if kind == "settling":
        y = np.zeros(n)
        n_events = int(rng.poisson(form["rate_per_h"] * span / 3600.0))
        times = list(rng.uniform(0.0, span, n_events))
        amps = list(rng.standard_normal(n_events))
        for start, _ in runs:
            kick = float(rng.standard_normal()) * 1.5 * form["run_start_step"]
            if kick != 0.0:
                times.append(start)
                amps.append(kick)
        for tk, ak in zip(times, amps):
            after = t > tk
            y[after] += ak * (1.0 - np.exp(-(t[after] - tk) / form["tau_s"]))
        if not np.any(y):  # no event at all: a gentle settling from the start
            y = (1.0 - np.exp(-t / form["tau_s"])) * float(np.sign(rng.standard_normal()) or 1.0)
        return y
    raise ValueError(kind)


def session_path(form: dict, rng: np.random.Generator, t: np.ndarray,
                 runs: list[tuple[float, float]]) -> np.ndarray:
    """A normalised path on the session grid ``t`` (s); ``runs``: (start, end) of every run (s)."""
    if form["kind"] == "mixture":
        y = sum(w * normalise(t, _component(c, rng, t, runs), runs)
                for w, c in zip(form["weights"], form["components"]))
    else:
        y = _component(form, rng, t, runs)
    return normalise(t, np.asarray(y, dtype=float), runs)


def session_grid(end_s: float) -> np.ndarray:
    return np.arange(0.0, end_s + 2 * GRID_S, GRID_S)
