"""Slow random paths over a run's time: the realisations of drifts.

``unit_path(desc, rng, t_s)`` is a dimensionless path of order one over a run of
a few hours; the caller scales it (by the strength and a unit amplitude).  Each
kind draws a fixed number of random numbers from ``rng`` whatever the times asked
for, so a path is a function of time only: it does not depend on the schedule,
on the strength or on the other mechanisms present.

Kinds (``desc["kind"]``), all in seconds:

* ``spectral``: a sum of 16 random sinusoids, periods log-uniform in
  ``[period_min_s, period_max_s]``, amplitudes ~ f**(-alpha/2) (a 1/f**alpha
  spectrum: alpha 1 flicker-like, 3 a smooth random-walk-like wander); rms one.
* ``warmup``: an exponential approach ``1 - exp(-t/tau)`` (electronics, laser,
  package settling after the run begins), with a small wander on top; its time
  constant, amplitude and (rarely) sign differ from run to run.
* ``ramp``: a smooth trend ``c1 (t/4h) + c2 (t/4h)**2`` with random coefficients
  (the room warming over the afternoon, a slow leak of alignment).
* ``cycle``: a periodic swing (air conditioning on its thermostat), period
  ``period_s``, a second harmonic ``skew``, random phase per run.
* ``settle``: mechanical settling: a logarithmic creep of the mount and a few
  random slips (smoothed steps of width ``width_s``, ``rate_per_h`` of them per hour).

``desc["zeroed"]`` (spectral only): subtract the path's value at the run's start.
"""

from __future__ import annotations

import numpy as np

_N_SINES = 16
_N_SLIPS = 8


def _spectral(desc: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    f_lo, f_hi = 1.0 / float(desc["period_max_s"]), 1.0 / float(desc["period_min_s"])
    f = np.exp(rng.uniform(np.log(f_lo), np.log(f_hi), _N_SINES))
    phase = rng.uniform(0.0, 2.0 * np.pi, _N_SINES)
    amp = rng.rayleigh(1.0, _N_SINES) * np.power(f / f_lo, -0.5 * float(desc["alpha"]))
    amp = amp / np.sqrt(0.5 * np.sum(amp**2))
    out = np.cos(2.0 * np.pi * t[:, None] * f[None, :] + phase[None, :]) @ amp
    if desc.get("zeroed", False):
        out = out - float(np.cos(phase) @ amp)
    return out


def _wander(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    return _spectral({"period_min_s": 600.0, "period_max_s": 20_000.0, "alpha": 2.0, "zeroed": True}, rng, t)


def _warmup(desc: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    tau = float(desc["tau_s"]) * float(np.exp(rng.normal(0.0, 0.3)))
    amp = float(np.exp(rng.normal(0.0, 0.3))) * (1.0 if rng.uniform() > 0.2 else -1.0)
    return amp * (1.0 - np.exp(-t / tau)) + 0.15 * _wander(rng, t)


def _ramp(desc: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    c1 = float(rng.uniform(0.4, 1.2)) * (1.0 if rng.uniform() < 0.5 else -1.0)
    c2 = float(rng.normal(0.0, 0.3))
    x = t / 14_400.0
    return c1 * x + c2 * x * x


def _cycle(desc: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    period = float(desc["period_s"]) * float(np.exp(rng.normal(0.0, 0.05)))
    phase = rng.uniform(0.0, 2.0 * np.pi)
    amp = float(np.exp(rng.normal(0.0, 0.2)))
    w = 2.0 * np.pi * t / period
    skew = float(desc["skew"])
    return amp * (np.sin(w + phase) + skew * np.sin(2.0 * (w + phase))) / np.sqrt(0.5 * (1.0 + skew**2)) / np.sqrt(2.0)


def _settle(desc: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    tau_log = float(np.exp(rng.uniform(np.log(60.0), np.log(1200.0))))
    s = 1.0 if rng.uniform() < 0.5 else -1.0
    out = s * np.log1p(t / tau_log) / np.log1p(10_800.0 / tau_log)
    count = rng.poisson(float(desc["rate_per_h"]) * 4.0)
    times = rng.uniform(0.0, 4.0 * 3600.0, _N_SLIPS)
    amps = rng.normal(0.0, 0.6, _N_SLIPS)
    width = float(desc["width_s"])
    for j in range(min(count, _N_SLIPS)):
        out = out + amps[j] * 0.5 * (np.tanh((t - times[j]) / width) - np.tanh(-times[j] / width))
    return out


_KINDS = {"spectral": _spectral, "warmup": _warmup, "ramp": _ramp, "cycle": _cycle, "settle": _settle}


def unit_path(desc: dict, rng: np.random.Generator, t_s: np.ndarray) -> np.ndarray:
    """The path of ``desc`` drawn from ``rng`` at times ``t_s`` (s), order one."""
    return _KINDS[desc["kind"]](desc, rng, np.asarray(t_s, dtype=float))


def draw_path_desc(rng: np.random.Generator, kinds: tuple[str, ...]) -> dict:
    """A random path form among ``kinds``, with its shape parameters."""
    kind = str(kinds[int(rng.integers(len(kinds)))])
    lu = lambda a, b: float(np.exp(rng.uniform(np.log(a), np.log(b))))  # noqa: E731
    if kind == "spectral":
        return {"kind": kind, "alpha": float(rng.uniform(1.0, 3.0)), "period_min_s": lu(300.0, 1800.0),
                "period_max_s": lu(10_800.0, 43_200.0), "zeroed": bool(rng.uniform() < 0.5)}
    if kind == "warmup":
        return {"kind": kind, "tau_s": lu(600.0, 5400.0)}
    if kind == "ramp":
        return {"kind": kind}
    if kind == "cycle":
        return {"kind": kind, "period_s": lu(600.0, 3600.0), "skew": float(rng.uniform(0.0, 0.5))}
    if kind == "settle":
        return {"kind": kind, "rate_per_h": float(rng.uniform(0.3, 2.0)), "width_s": lu(20.0, 600.0)}
    raise ValueError(kind)


def lowpass_on_grid(values_at, t_s: np.ndarray, tau_s: float, step_s: float = 5.0) -> np.ndarray:
    """A first-order low-pass (time constant ``tau_s``) of the path ``values_at(times)``, at ``t_s``.

    Computed causally on a fixed grid ``0, step, 2 step...`` from the run's start (the
    package in equilibrium at the start), so a value never depends on how long the run is.
    """
    t = np.asarray(t_s, dtype=float)
    n = int(np.ceil(max(float(np.max(t, initial=0.0)), 0.0) / step_s)) + 2
    grid = np.arange(n) * step_s
    x = values_at(grid)
    a = float(np.exp(-step_s / tau_s))
    y = np.empty_like(x)
    acc = float(x[0])
    for i, xi in enumerate(x.tolist()):
        acc = a * acc + (1.0 - a) * xi
        y[i] = acc
    return np.interp(t, grid, y)
