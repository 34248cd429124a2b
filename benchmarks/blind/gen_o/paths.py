"""Realisations of the slow drifts: one unit-scale path per (seed, run, mechanism).

Each component of a drift form is realised on a fixed 10 s grid covering the
run (and the heater-off pause before it) from a random stream of its own,
seeded by (seed, run index, mechanism name, component index).  The path
therefore does not depend on the strength (it is scaled afterwards), nor on the
other mechanisms present, nor on the runs that follow.  Every component is of
order one (unit rms or unit amplitude); the form's weights have unit total
power.
"""

from __future__ import annotations

import math
import zlib

import numpy as np

GEN_TAG = 0x6E0_0B1D  # this generator's tag in every seed sequence
GRID_S = 10.0


def tag(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def stream(seed: int, *keys: int) -> np.random.Generator:
    s = int(seed) % (1 << 64)
    return np.random.default_rng(np.random.SeedSequence([GEN_TAG, s & 0xFFFFFFFF, s >> 32, *keys]))


def _smooth(x: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """First-order low-pass filter (exact for a piecewise-constant input), starting settled."""
    a = math.exp(-dt / tau)
    y = np.empty_like(x)
    acc = x[0]
    for i, xi in enumerate(x):
        acc = a * acc + (1.0 - a) * xi
        y[i] = acc
    return y


def _component(c: dict, rng: np.random.Generator, t: np.ndarray, run_index: int) -> np.ndarray:
    kind = c["kind"]
    n = t.size
    dt = GRID_S
    if kind == "ou":
        a = math.exp(-dt / c["tau_s"])
        xi = rng.standard_normal(n)
        x = np.empty(n)
        x[0] = xi[0]
        b = math.sqrt(1.0 - a * a)
        for i in range(1, n):
            x[i] = a * x[i - 1] + b * xi[i]
        return x
    if kind == "random_walk":
        steps = rng.standard_normal(n) * c["per_sqrt_hour"] * math.sqrt(dt / 3600.0)
        x = np.cumsum(steps)
        return x - x[np.searchsorted(t, 0.0)]
    if kind == "ac_cycle":
        period, duty, jit = c["period_s"], c["duty"], c["period_jitter"]
        # cycle boundaries with jittered periods, starting at a random phase
        start = t[0] - rng.uniform(0.0, period)
        edges = [start]
        while edges[-1] <= t[-1]:
            edges.append(edges[-1] + period * max(0.3, 1.0 + jit * rng.standard_normal()))
        edges = np.array(edges)
        k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 2)
        ph = (t - edges[k]) / (edges[k + 1] - edges[k])
        # warms linearly for a fraction ``duty`` of the cycle, cooled for the rest
        tri = np.where(ph < duty, -1.0 + 2.0 * ph / duty, 1.0 - 2.0 * (ph - duty) / (1.0 - duty))
        return _smooth(tri, c["smooth_s"], dt) * math.sqrt(3.0)
    if kind == "day":
        phase = rng.uniform(0.0, 2 * math.pi)
        return math.sqrt(2.0) * np.sin(2 * math.pi * t / c["period_s"] + phase)
    if kind == "warmup":
        # the first run of the day warms up from cold; later ones start partly warm
        m = rng.uniform(0.8, 1.5) if run_index == 0 else rng.uniform(0.2, 0.7)
        return c["sign"] * m * np.exp(-np.maximum(t, 0.0) / c["tau_s"]) * 1.5
    if kind == "hops":
        mean = c["mean_dwell_s"]
        state = 1.0 if rng.uniform() < 0.5 else -1.0
        raw = np.empty(n)
        next_hop = t[0] + rng.exponential(mean)
        for i, ti in enumerate(t):
            while ti >= next_hop:
                state = -state
                next_hop += rng.exponential(mean)
            raw[i] = state
        return _smooth(raw, c["smooth_s"], dt)
    if kind == "events":
        rate = c["rate_per_h"] / 3600.0
        times = []
        te = t[0] - 3.0 * c["recover_s"] + rng.exponential(1.0 / rate)
        while te < t[-1]:
            times.append(te)
            te += rng.exponential(1.0 / rate)
        x = np.zeros(n)
        r1, r2 = c["rise_s"], c["recover_s"]
        if r1 >= r2:
            r1 = 0.5 * r2
        tp = math.log(r2 / r1) * r1 * r2 / (r2 - r1)
        peak = math.exp(-tp / r2) - math.exp(-tp / r1)
        for te in times:
            amp = rng.uniform(0.5, 1.5)
            s = np.maximum(t - te, 0.0)
            x += amp * (np.exp(-s / r2) - np.exp(-s / r1)) / peak
        return c["sign"] * 1.5 * x
    if kind == "settling":
        rate = c["rate_per_h"] / 3600.0
        x = np.zeros(n)
        te = t[0] + rng.exponential(1.0 / rate)
        while te < t[-1]:
            s = np.maximum(t - te, 0.0)
            x += rng.normal(0.0, 1.0) * (1.0 - np.exp(-s / c["settle_s"]))
            te += rng.exponential(1.0 / rate)
        return x
    raise ValueError(kind)


class DriftPath:
    """A drift's unit path for one run, evaluated at any time of that run (s)."""

    def __init__(self, form: dict, seed: int, run_index: int, family: str, t0: float, t1: float):
        t = np.arange(math.floor(t0 / GRID_S) - 1, math.ceil(t1 / GRID_S) + 2) * GRID_S
        self._t = t
        x = np.zeros(t.size)
        for k, c in enumerate(form["components"]):
            rng = stream(seed, run_index, tag(family), k)
            x += c["weight"] * _component(c, rng, t, run_index)
        self._x = x

    def __call__(self, times) -> np.ndarray:
        return np.interp(times, self._t, self._x)


__all__ = ["DriftPath", "GRID_S", "stream", "tag"]
