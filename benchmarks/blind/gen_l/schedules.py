"""Schedules like the session's (for this generator's own tests and measurements only)."""

from __future__ import annotations

import numpy as np


def identification(levels: int = 30, v_max: float = 6.0, dwell_s: float = 20.0, readings: int = 20) -> dict:
    """Damped oscillation on the grid's walls (0 -> top -> 1 -> top-1 -> ...) and one last point: 467 set-points."""
    idx = [0]
    lo, hi, up = 0, levels, True
    while lo < hi:
        if up:
            idx.extend(range(idx[-1] + 1, hi + 1))
            lo += 1
        else:
            idx.extend(range(idx[-1] - 1, lo - 1, -1))
            hi -= 1
        up = not up
    v = np.asarray(idx, float) * v_max / levels
    v = np.r_[v, v_max / 2 + v_max / levels / 2]
    return {"v_V": v, "dwell_s": np.full(v.size, dwell_s), "readings": readings}


def check(seed: int = 0, n: int = 360, v_max: float = 6.0, readings: int = 20) -> dict:
    """Random reversals, steps from mV to the whole range, 8-60 s dwells, some repeats."""
    rng = np.random.default_rng(seed)
    v = np.empty(n)
    x, d = 0.0, 1.0
    for i in range(n):
        if i and rng.uniform() < 0.08:
            v[i] = v[i - 1]
            continue
        if rng.uniform() < 0.35:
            d = -d
        step = float(np.exp(rng.uniform(np.log(0.001), np.log(v_max))))
        x = float(np.clip(x + d * step, 0.0, v_max))
        if x in (0.0, v_max):
            d = -d
        v[i] = x
    return {"v_V": v, "dwell_s": rng.uniform(8.0, 60.0, n), "readings": readings}


def session(seed: int = 0) -> list[dict]:
    return [identification(), check(seed)]


def short(n: int = 40, seed: int = 0) -> list[dict]:
    """A short two-run session for quick tests."""
    a = identification()
    b = check(seed, n=n)
    return [{"v_V": a["v_V"][::12][:n], "dwell_s": a["dwell_s"][:n], "readings": 10}, b]
