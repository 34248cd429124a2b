"""Slow random paths over one run: the shape of a drift (ambient, PSD zero, PSD gain).

A path is dimensionless with an rms of about 1 over a run of a few hours; the
mechanism that uses it multiplies it by its amplitude (K, um or a relative
gain) times the strength, so the realisation never depends on the strength.

The *form* (which kinds of component, their time scales and weights) is drawn by
:func:`draw_path_form`; the *realisation* (phases, initial values, increments)
by :class:`SlowPath` from a stream of the run's own.

Component kinds, all plausible for a lab over minutes to hours:

``ou``        Ornstein-Uhlenbeck wander, correlation time 5 min to 2 h.
``spectral``  smooth 1/f^gamma wander: random-phase modes, periods 5 min to 4 h.
``walk``      Brownian random walk (unit rms after one hour): mechanical settling.
``settle``    exponential settling from a random start (warm-up), 8 to 60 min.
``cycle``     a slightly modulated periodic swing (air-conditioning cycle), 10 to 60 min.
``ramp``      a steady linear trend (unit at one hour) with random sign.
"""

from __future__ import annotations

import numpy as np

PATH_KINDS = ("ou", "spectral", "walk", "settle", "cycle", "ramp")

#: Time step (s) of the grid a path is realised on; paths are slow, so linear interpolation is exact enough.
GRID_S = 5.0


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def draw_path_form(rng: np.random.Generator) -> dict:
    """A random path form (JSON-safe): one or two components with relative weights (sum of squares 1)."""
    n = int(rng.integers(1, 3))
    kinds = [str(k) for k in rng.choice(PATH_KINDS, size=n, replace=False)]
    comps = []
    for kind in kinds:
        c: dict = {"kind": kind}
        if kind == "ou":
            c["tau_s"] = _logu(rng, 300.0, 7200.0)
        elif kind == "spectral":
            c["gamma"] = float(rng.uniform(0.5, 2.0))
            c["period_min_s"] = _logu(rng, 300.0, 900.0)
            c["period_max_s"] = _logu(rng, 5400.0, 14400.0)
        elif kind == "settle":
            c["tau_s"] = _logu(rng, 480.0, 3600.0)
        elif kind == "cycle":
            c["period_s"] = _logu(rng, 600.0, 3600.0)
            c["modulation"] = float(rng.uniform(0.0, 0.4))
        comps.append(c)
    w = rng.uniform(0.4, 1.0, size=n)
    w = w / np.sqrt(np.sum(w ** 2))
    for c, wi in zip(comps, w):
        c["weight"] = float(wi)
    return {"components": comps}


class SlowPath:
    """A realised path on ``[0, t_end_s]`` (s), dimensionless, rms about 1; call it with times (s)."""

    def __init__(self, form: dict, component_rng, t_end_s: float) -> None:
        """``component_rng(i)``: the generator of component ``i`` (a stream of its own, so the number
        of grid points one component needs never shifts another's draws)."""
        n = int(np.ceil(max(t_end_s, 0.0) / GRID_S)) + 3
        self.t = np.arange(n) * GRID_S
        self.values = np.zeros(n)
        for i, comp in enumerate(form["components"]):
            self.values += float(comp["weight"]) * _component(comp, component_rng(i), self.t)

    def __call__(self, t_s: float | np.ndarray) -> float | np.ndarray:
        return np.interp(t_s, self.t, self.values)


def _component(comp: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """One unit-scale component on the grid ``t`` (s) ``(n,)``."""
    kind = comp["kind"]
    n = t.size
    if kind == "ou":
        a = np.exp(-GRID_S / float(comp["tau_s"]))
        xi = rng.standard_normal(n)
        x = np.empty(n)
        x[0] = xi[0]
        s = np.sqrt(1.0 - a * a)
        for i in range(1, n):
            x[i] = a * x[i - 1] + s * xi[i]
        return x
    if kind == "walk":
        steps = rng.standard_normal(n) * np.sqrt(GRID_S / 3600.0)
        steps[0] = 0.0
        return np.cumsum(steps)
    if kind == "spectral":
        m = 12
        f = np.geomspace(1.0 / float(comp["period_max_s"]), 1.0 / float(comp["period_min_s"]), m)
        amp = f ** (-float(comp["gamma"]) / 2.0)
        amp = amp / np.sqrt(np.sum(amp ** 2))
        a, b = rng.standard_normal(m), rng.standard_normal(m)
        ph = 2.0 * np.pi * np.outer(t, f)
        return (np.cos(ph) * (amp * a) + np.sin(ph) * (amp * b)).sum(axis=1)
    if kind == "settle":
        start = float(rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 2.0))
        return start * np.exp(-t / float(comp["tau_s"]))
    if kind == "cycle":
        phi, phi2 = rng.uniform(0.0, 2.0 * np.pi, size=2)
        p = float(comp["period_s"])
        mod = 1.0 + float(comp["modulation"]) * np.sin(2.0 * np.pi * t / (5.3 * p) + phi2)
        return np.sqrt(2.0) * np.sin(2.0 * np.pi * t / p + phi) * mod
    if kind == "ramp":
        slope = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.5))
        return slope * t / 3600.0
    raise ValueError(f"unknown path kind {kind!r}")
