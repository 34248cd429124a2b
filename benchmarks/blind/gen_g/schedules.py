"""Example schedules of generator G's own (for its tests): an identification run and a check run."""

from __future__ import annotations

import numpy as np


def damped_oscillation_levels(levels: int) -> list[int]:
    """Wall indices of a damped oscillation: ``levels (levels + 1) / 2 + 2`` set-points.

    From rest, for every amplitude ``a = L, L-1, ..., 1`` the input swings between the walls
    ``a, 0, a-1, 1, a-2, ...`` (``a`` set-points, converging on the middle), so every cell of the
    Preisach triangle is reversed on at least once; a first set-point at wall 0 and a last one at
    the middle wall complete the ``L (L + 1) / 2 + 2`` points (467 for ``L = 30``).
    """
    seq = [0]
    for a in range(levels, 0, -1):
        hi, lo = a, 0
        part = []
        while len(part) < a:
            part.append(hi)
            if len(part) < a:
                part.append(lo)
            hi -= 1
            lo += 1
        seq.extend(part)
    seq.append(levels // 2)
    return seq


def identification_schedule(device, dwell_s: float = 20.0, readings: int = 10) -> dict:
    L = device.levels
    walls = device.v_min_V + np.arange(L + 1) * (device.v_max_V - device.v_min_V) / L
    v = walls[np.array(damped_oscillation_levels(L))]
    return {"v_V": v, "dwell_s": np.full(len(v), float(dwell_s)), "readings": int(readings)}


def check_schedule(device, seed: int = 0, n: int = 360, readings: int = 10) -> dict:
    """Random reversals, steps from millivolts to the whole range, dwells 8-60 s, some repeats."""
    rng = np.random.default_rng(np.random.SeedSequence([7_171, int(seed)]))
    lo, hi = device.v_min_V, device.v_max_V
    v = np.empty(n)
    x, d = lo + 0.3 * (hi - lo), 1.0
    for i in range(n):
        u = rng.random()
        if u < 0.08 and i > 0:
            v[i] = v[i - 1]                      # a repeated set-point
            continue
        if rng.random() < 0.35:
            d = -d                               # a reversal
        step = float(np.exp(rng.uniform(np.log(1e-3), np.log(hi - lo))))
        x = x + d * step
        while x > hi or x < lo:               # reflect off the ends of the range
            x = 2 * hi - x if x > hi else 2 * lo - x
            d = -d
        v[i] = round(x, 4)
    dwell = np.round(rng.uniform(8.0, 60.0, size=n), 1)
    return {"v_V": v, "dwell_s": dwell, "readings": int(readings)}


def session(device, seed: int = 0) -> list[dict]:
    return [identification_schedule(device), check_schedule(device, seed)]
