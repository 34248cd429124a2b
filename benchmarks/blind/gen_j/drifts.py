"""Lab disturbance processes: unit-scale random paths of a drift over one run.

Every path is drawn from its own stream (seed, run, family, component), so it
does not depend on the strength, on the other mechanisms present, nor on the
runs that follow.  The scale of every component is of order one (an rms or a
typical excursion over a few hours of about one); the mechanism multiplies it
by its strength.
"""

from __future__ import annotations

import zlib

import numpy as np

_MAGIC = 0x6A_0B1D  # generator J

GRID_DT_S = 5.0


def family_key(name: str) -> int:
    """A stable integer for a name (Python's ``hash`` is salted per process)."""
    return int(zlib.crc32(name.encode("utf-8")))


def stream(seed: int, *keys: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([_MAGIC, int(seed) & 0xFFFFFFFF, *[int(k) for k in keys]]))


def _ou(grid, rng, tau, stationary):
    dt = GRID_DT_S
    a = np.exp(-dt / tau)
    e = rng.normal(size=grid.size) * np.sqrt(1.0 - a * a)
    x = np.empty(grid.size)
    x[0] = rng.normal() if stationary else 0.0
    for i in range(1, grid.size):
        x[i] = a * x[i - 1] + e[i]
    return x


def _random_walk(grid, rng):
    steps = rng.normal(size=grid.size) * np.sqrt(GRID_DT_S / 3600.0)  # std 1 after one hour
    steps[0] = 0.0
    return np.cumsum(steps)


def _warmup(grid, rng, comp):
    amp = comp["sign"] * float(np.clip(1.0 + 0.3 * rng.normal(), 0.3, 1.8))
    since = min(comp["since_on_tau"] * float(rng.uniform(0.5, 1.5)), 1.2)  # this run's start, in tau
    tau = comp["tau_s"]
    # the part of the settling still to come when the run starts (at least 30 % of it)
    return 1.5 * amp * np.exp(-since) * (1.0 - np.exp(-grid / tau))


def _flicker(grid, rng, alpha):
    n = grid.size
    m = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfftfreq(m, GRID_DT_S)
    spec = np.zeros(f.size, dtype=complex)
    spec[1:] = (rng.normal(size=f.size - 1) + 1j * rng.normal(size=f.size - 1)) * f[1:] ** (-alpha / 2.0)
    x = np.fft.irfft(spec, m)[:n]
    x = x - x.mean()
    sd = x.std()
    return x / sd if sd > 0 else x


def _hvac(grid, rng, comp):
    period, shape, duty, jitter = comp["period_s"], comp["shape"], comp["duty"], comp["jitter"]
    wobble = _ou(grid, rng, period, True)
    rate = (1.0 + jitter * wobble) / period
    phase = rng.uniform() + np.concatenate([[0.0], np.cumsum(rate[:-1] * GRID_DT_S)])
    frac = phase % 1.0
    if shape == "sine":
        wave = np.sin(2.0 * np.pi * frac)
    elif shape == "triangle":
        wave = 1.0 - 4.0 * np.abs(frac - 0.5)
    else:  # asymmetric sawtooth: the heater (or chiller) on for a fraction ``duty`` of the cycle
        wave = np.where(frac < duty, -1.0 + 2.0 * frac / duty, 1.0 - 2.0 * (frac - duty) / (1.0 - duty))
    amp = float(np.clip(1.0 + 0.15 * rng.normal(), 0.5, 1.5))
    return amp * wave


def _diurnal(grid, rng_session, comp, session_start_s):
    day_phase = rng_session.uniform()
    w = 2.0 * np.pi / comp["period_s"]
    t = session_start_s + grid
    # relative to the start of the session; 1.3 units ~ the change over a few hours at the steepest
    return 1.3 * comp["period_s"] / (3.0 * 3600.0) / (2.0 * np.pi) * (
        np.sin(w * t + 2.0 * np.pi * day_phase) - np.sin(2.0 * np.pi * day_phase))


def _events(grid, rng, comp, kind):
    t_end = grid[-1]
    n = max(1, int(rng.poisson(comp["rate_per_h"] * t_end / 3600.0)))  # at least one in a run of hours
    times = np.sort(rng.uniform(0.0, t_end, size=n))
    x = np.zeros(grid.size)
    for te in times:
        dt = np.clip(grid - te, 0.0, None)
        on = grid >= te
        if kind == "doors":  # the room cools while the door is open, then recovers
            size = -abs(rng.normal(1.0, 0.5)) if rng.uniform() < 0.8 else abs(rng.normal(0.6, 0.3))
            x += on * size * (1.0 - np.exp(-dt / comp["onset_s"])) * np.exp(-dt / comp["recover_s"])
        else:  # the mount slips and settles to a new rest position
            size = rng.normal(0.0, 0.8)
            x += on * size * (1.0 - np.exp(-dt / comp["settle_s"]))
    return x


def _mode_hops(grid, rng, comp):
    levels = np.linspace(-1.0, 1.0, comp["levels"])
    x = np.empty(grid.size)
    state = int(rng.integers(comp["levels"]))
    t_next = rng.exponential(comp["mean_dwell_s"])
    for i, t in enumerate(grid):
        while t >= t_next:
            state = int((state + rng.integers(1, comp["levels"])) % comp["levels"])
            t_next += rng.exponential(comp["mean_dwell_s"])
        x[i] = levels[state]
    return x


def drift_path(form: dict, family: str, seed: int, run: int, t_end_s: float, session_start_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The unit-scale path of a drift over one run: ``(grid_s, values)`` on a 5 s grid from 0 to past ``t_end_s``."""
    grid = np.arange(0.0, float(t_end_s) + 3.0 * GRID_DT_S, GRID_DT_S)
    fk = family_key(family)
    total = np.zeros(grid.size)
    for j, comp in enumerate(form["components"]):
        rng = stream(seed, 1, run, fk, 100 + j)
        kind = comp["kind"]
        if kind == "ou":
            x = _ou(grid, rng, comp["tau_s"], comp["stationary_start"])
        elif kind == "random_walk":
            x = _random_walk(grid, rng)
        elif kind == "warmup":
            x = _warmup(grid, rng, comp)
        elif kind == "flicker":
            x = _flicker(grid, rng, comp["alpha"])
        elif kind == "hvac":
            x = _hvac(grid, rng, comp)
        elif kind == "diurnal":
            x = _diurnal(grid, stream(seed, 2, fk, 100 + j), comp, session_start_s)
        elif kind in ("doors", "slips"):
            x = _events(grid, rng, comp, kind)
        elif kind == "mode_hops":
            x = _mode_hops(grid, rng, comp)
        else:
            raise ValueError(f"unknown drift component {kind!r}")
        total += np.sqrt(comp["weight"]) * x
    return grid, total


__all__ = ["GRID_DT_S", "drift_path", "family_key", "stream"]
