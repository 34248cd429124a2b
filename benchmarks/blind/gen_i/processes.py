"""Slow random processes of a rig (drifts), each of unit size, realised on a time grid of one run.

A component is a dict with a ``kind`` and its parameters (drawn by ``forms``); its realisation in a
run comes from a stream of its own, keyed by (seed, run, family, component index): it does not
depend on the strength, on the other mechanisms, nor on the runs that follow.

Kinds (all of typical size 1 over a few hours):

* ``random_walk``  Brownian motion (laser pointing, slow electronics wander), std 1 after 3 h, from 0.
* ``ou``           Ornstein-Uhlenbeck (mean-reverting wander), correlation time ``tau_s``, std 1.
* ``flicker``      1/f-like: four OU processes with log-spaced correlation times in
                   [``tau_min_s``, ``tau_max_s``], std 1 in all.
* ``warmup``       A warm-up transient ``sign * a * (1 - exp(-t / tau_s))`` (or the decay of a
                   previous warm state, ``shape = "decay"``), ``a`` drawn per run in [0.5, 1.3].
* ``hvac``         The air-conditioning cycle: a periodic wave (``sine``, ``triangle`` or
                   thermostat ``sawtooth`` with heating fraction ``duty``), period ``period_s`` with a
                   5 % jitter per run, random phase, through a first-order thermal mass ``filter_s``
                   (gain-compensated at the fundamental), amplitude drawn per run in [0.7, 1.3].
* ``steps``        Mechanical settling / slips: Poisson events (``rate_per_h``), N(0, 0.7) sizes,
                   each relaxing into place with ``settle_s`` (``0`` for sharp steps, e.g. mode hops).
* ``trend``        A straight line with N(0, 1) slope per 3 h.
* ``log_settle``   Logarithmic settling ``sign * a * log(1 + t / tau_s) / log(1 + 3 h / tau_s)``.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from ._util import stream

_REF_S = 10_800.0  # 3 h
_DT_S = 5.0


def _ou(rng: np.random.Generator, n: int, tau_s: float, dt: float) -> np.ndarray:
    a = float(np.exp(-dt / tau_s))
    x0 = float(rng.standard_normal())
    e = rng.standard_normal(n - 1) * np.sqrt(1.0 - a * a)
    rest = lfilter([1.0], [1.0, -a], e, zi=[a * x0])[0]
    return np.concatenate([[x0], rest])


def _wave(kind: str, phase: np.ndarray, duty: float) -> np.ndarray:
    f = np.mod(phase, 1.0)
    if kind == "sine":
        return np.sin(2 * np.pi * f)
    if kind == "triangle":
        return 2.0 * np.abs(2.0 * f - 1.0) - 1.0
    # thermostat sawtooth: rises during `duty` of the period, falls in the rest
    return np.where(f < duty, -1.0 + 2.0 * f / duty, 1.0 - 2.0 * (f - duty) / (1.0 - duty))


def _lowpass(x: np.ndarray, tau_s: float, dt: float) -> np.ndarray:
    if tau_s <= 0:
        return x
    a = float(np.exp(-dt / tau_s))
    return lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])[0]


def unit_component(comp: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    kind = comp["kind"]
    n = t.size
    dt = float(t[1] - t[0])
    if kind == "random_walk":
        steps = rng.standard_normal(n - 1) * np.sqrt(dt / _REF_S)
        return np.concatenate([[0.0], np.cumsum(steps)])
    if kind == "ou":
        return _ou(rng, n, float(comp["tau_s"]), dt)
    if kind == "flicker":
        taus = np.geomspace(float(comp["tau_min_s"]), float(comp["tau_max_s"]), 4)
        return sum(_ou(rng, n, float(tau), dt) for tau in taus) / 2.0
    if kind == "warmup":
        a = float(rng.uniform(0.5, 1.3)) * float(comp["sign"])
        e = np.exp(-t / float(comp["tau_s"]))
        return a * (e if comp.get("shape") == "decay" else 1.0 - e)
    if kind == "hvac":
        period = float(comp["period_s"]) * (1.0 + 0.05 * float(rng.standard_normal()))
        phase0 = float(rng.uniform())
        amp = float(rng.uniform(0.7, 1.3))
        tau = float(comp.get("filter_s", 0.0))
        lead = 5.0 * tau
        tt = np.concatenate([t[0] - lead + dt * np.arange(int(np.ceil(lead / dt))), t]) if tau > 0 else t
        w = _wave(comp["wave"], phase0 + tt / period, float(comp.get("duty", 0.7)))
        w = _lowpass(w, tau, dt)[tt.size - n:]
        gain = 1.0 / np.sqrt(1.0 + (2 * np.pi * tau / period) ** 2)
        return amp * w / gain
    if kind == "steps":
        rate = float(comp["rate_per_h"]) / 3600.0
        settle = float(comp.get("settle_s", 0.0))
        out = np.zeros(n)
        tk = 0.0
        while True:
            tk += float(rng.exponential(1.0 / rate))
            if tk >= t[-1]:
                break
            size = 0.7 * float(rng.standard_normal())
            d = t - tk
            if settle > 0:
                out += size * np.where(d > 0, -np.expm1(-np.maximum(d, 0.0) / settle), 0.0)
            else:
                out += size * (d >= 0)
        return out
    if kind == "trend":
        return float(rng.standard_normal()) * t / _REF_S
    if kind == "log_settle":
        a = float(rng.uniform(0.5, 1.3)) * float(comp["sign"])
        tau = float(comp["tau_s"])
        return a * np.log1p(t / tau) / np.log1p(_REF_S / tau)
    raise ValueError(f"unknown drift component {kind!r}")


class Path:
    """A realised drift of one run: ``path(t)`` for run times ``t`` (s), linear between grid points."""

    def __init__(self, components: list, filter_s: float, seed: int, run: int, family: str, t_end_s: float):
        n = int(np.ceil(max(t_end_s, 1.0) / _DT_S)) + 3
        self.t = _DT_S * np.arange(n)
        total = np.zeros(n)
        for k, comp in enumerate(components):
            rng = stream(seed, run, family, 1000 + k)
            total += float(comp["weight"]) * unit_component(comp, rng, self.t)
        if filter_s and filter_s > 0:
            # e.g. the package's thermal mass between the room and the film
            total = _lowpass(total, float(filter_s), _DT_S)
        self.values = total

    def __call__(self, t):
        return np.interp(t, self.t, self.values)
