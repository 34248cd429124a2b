"""Example schedules of this folder's tests (written from SPEC.md's description only)."""

from __future__ import annotations

import numpy as np


def identification_schedule(levels: int = 30, v_min: float = 0.0, v_max: float = 6.0,
                            dwell_s: float = 20.0, readings: int = 20) -> dict:
    """The damped oscillation on the grid's walls: 0 -> top -> wall 1 -> wall L-1 -> ... (walls
    one by one), ``levels (levels + 1) / 2 + 1`` set-points, plus a last one (the top wall):
    467 set-points for 30 levels, 20 s dwells."""
    walls = np.linspace(v_min, v_max, levels + 1)
    idx = [0]
    lo, hi, up = 0, levels, True
    cur = 0
    while lo < hi:
        if up:
            idx.extend(range(cur + 1, hi + 1))
            cur, lo = hi, lo + 1
        else:
            idx.extend(range(cur - 1, lo - 1, -1))
            cur, hi = lo, hi - 1
        up = not up
    idx.append(levels)
    v = walls[np.array(idx)]
    return {"v_V": v, "dwell_s": np.full(v.size, float(dwell_s)), "readings": int(readings)}


def check_schedule(n: int = 360, seed: int = 7, v_min: float = 0.0, v_max: float = 6.0,
                   readings: int = 20) -> dict:
    """Random reversals, steps from millivolts to the whole range, dwells 8-60 s, some repeats."""
    rng = np.random.default_rng(seed)
    v = np.empty(n)
    cur, direction = v_min, 1.0
    for k in range(n):
        r = rng.random()
        if k > 0 and r < 0.08:
            v[k] = cur  # a repeated set-point
            continue
        if rng.random() < 0.35:
            direction = -direction
        step = float(np.exp(rng.uniform(np.log(1e-3), np.log(v_max - v_min))))
        nxt = cur + direction * step
        if nxt > v_max or nxt < v_min:
            direction = -direction
            nxt = min(max(cur + direction * step, v_min), v_max)
        cur = float(np.round(nxt, 4))
        v[k] = cur
    dwell = np.exp(rng.uniform(np.log(8.0), np.log(60.0), n))
    return {"v_V": v, "dwell_s": dwell, "readings": int(readings)}


def session(levels: int = 30, readings: int = 20) -> list[dict]:
    return [identification_schedule(levels, readings=readings), check_schedule(readings=readings)]
