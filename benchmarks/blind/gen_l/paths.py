"""Slow random paths (unit scale) for the drifts: one realisation per run, drawn from its own stream.

A path is generated on a lattice of ``LATTICE_S`` seconds covering the run and
interpolated linearly at any time; its typical size over a run of a few hours
is of order one.  Every random number comes from the ``rng`` handed in, so a
path depends only on (seed, run, mechanism) and never on the strength.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

LATTICE_S = 10.0


def _ou(rng, n, dt, tau, x0=0.0):
    a = np.exp(-dt / tau)
    xi = rng.standard_normal(n)
    xi[0] = 0.0
    y, _ = lfilter([np.sqrt(1.0 - a * a)], [1.0, -a], xi, zi=[a * x0])
    return y


def _smooth(x, dt, tau):
    a = np.exp(-dt / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y


def _wave(kind, phase):
    p = np.mod(phase, 1.0)
    if kind == "sine":
        return np.sin(2 * np.pi * p)
    if kind == "triangle":
        return 4.0 * np.abs(p - 0.5) - 1.0
    # thermostat: slow warm-up then a quick fall (sawtooth with a 15 % return)
    return np.where(p < 0.85, -1.0 + 2.0 * p / 0.85, 1.0 - 2.0 * (p - 0.85) / 0.15)


class DriftPath:
    """A unit-scale slow path ``f(t)`` over ``[0, t_end_s]`` (s) of a form ``{"kind": ...}``."""

    def __init__(self, form: dict, rng: np.random.Generator, t_end_s: float, smooth_s: float = 0.0):
        n = int(np.ceil(max(t_end_s, 0.0) / LATTICE_S)) + 3
        dt = LATTICE_S
        t = np.arange(n) * dt
        kind = form["kind"]
        if kind == "ou":
            x = _ou(rng, n, dt, form["tau_s"])
        elif kind == "random_walk":
            steps = rng.standard_normal(n) * np.sqrt(dt / 3600.0)
            steps[0] = 0.0
            x = _smooth(np.cumsum(steps), dt, form["smooth_s"])
        elif kind == "warmup":
            amp = rng.choice((-1.0, 1.0)) * rng.uniform(0.6, 1.4)
            x = amp * (1.0 - np.exp(-t / form["tau_s"]))
            x = x + form["residual"] * _ou(rng, n, dt, form["residual_tau_s"])
        elif kind == "periodic":
            period = form["period_s"] * rng.uniform(0.9, 1.1)
            amp = rng.uniform(0.6, 1.2)
            x = amp * _wave(form["wave"], t / period + rng.uniform())
            x = x - x[0]
            x = x + form["trend"] * _ou(rng, n, dt, 7200.0)
        elif kind == "pink":
            m = int(form["components"])
            taus = np.geomspace(form["tau_lo_s"], form["tau_hi_s"], m)
            x = sum(_ou(rng, n, dt, tau) for tau in taus) / np.sqrt(m) * 1.4
        elif kind == "steps":
            n_steps = rng.poisson(max(t_end_s, 0.0) / form["mean_gap_s"])
            times = np.sort(rng.uniform(0.0, max(t_end_s, 1.0), n_steps))
            sizes = rng.normal(0.0, 0.7, n_steps)
            raw = np.zeros(n)
            for tt, s in zip(times, sizes):
                raw[t >= tt] += s
            walk = np.cumsum(np.r_[0.0, rng.standard_normal(n - 1)] * np.sqrt(dt / 3600.0))
            x = _smooth(raw, dt, form["settle_s"]) + form["walk"] * walk
        else:
            raise ValueError(f"unknown drift path kind {kind!r}")
        if smooth_s > 0.0:
            x = _smooth(x, dt, smooth_s)
        self._t = t
        self._x = np.asarray(x, dtype=float)

    def __call__(self, t_s) -> np.ndarray:
        return np.interp(np.asarray(t_s, dtype=float), self._t, self._x)
