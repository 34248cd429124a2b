"""Example schedules of this lab's bench, for the tests and for trying the generator by hand.

* :func:`identification_run`: the damped oscillation on the walls of the 30-level grid
  (467 set-points, 20 s dwells): a rest point at the lower wall, then the nested damped
  oscillations ``D_m`` for ``m = L .. 1`` (``D_m``: ``m`` points alternating between the
  walls ``m, 0, m-1, 1, ...``), then back to the lower wall.
* :func:`check_run`: about 360 set-points with random reversals, step sizes drawn
  log-uniformly from 1 mV to the whole range, dwells 8-60 s and some repeated set-points.
"""

from __future__ import annotations

import numpy as np

LEVELS = 30
V_MIN, V_MAX = 0.0, 6.0


def walls(levels: int = LEVELS, v_min: float = V_MIN, v_max: float = V_MAX) -> np.ndarray:
    return v_min + (v_max - v_min) * np.arange(levels + 1) / levels


def damped_oscillation_indices(levels: int = LEVELS) -> list[int]:
    idx = [0]
    for m in range(levels, 0, -1):
        hi, lo, stage = m, 0, []
        while len(stage) < m:
            stage.append(hi)
            hi -= 1
            if len(stage) < m:
                stage.append(lo)
                lo += 1
        idx.extend(stage)
    idx.append(0)
    return idx


def identification_run(readings: int = 8, levels: int = LEVELS, v_min: float = V_MIN,
                       v_max: float = V_MAX, dwell_s: float = 20.0) -> dict:
    w = walls(levels, v_min, v_max)
    v = w[np.array(damped_oscillation_indices(levels))]
    return {"v_V": v, "dwell_s": np.full(v.size, float(dwell_s)), "readings": int(readings)}


def check_run(seed: int = 0, n: int = 360, readings: int = 8, v_min: float = V_MIN,
              v_max: float = V_MAX, repeat_p: float = 0.1) -> dict:
    rng = np.random.default_rng(np.random.SeedSequence([7_710_2, int(seed)]))
    v = np.empty(n)
    x = float(rng.uniform(v_min, v_max))
    direction = 1.0
    for k in range(n):
        if k > 0 and rng.random() >= repeat_p:
            if rng.random() < 0.5:
                direction = -direction
            step = float(np.exp(rng.uniform(np.log(1e-3), np.log(v_max - v_min))))
            x = x + direction * step
            if x > v_max:
                x, direction = 2 * v_max - x, -1.0
            if x < v_min:
                x, direction = 2 * v_min - x, 1.0
            x = float(np.clip(x, v_min, v_max))
        v[k] = round(x, 3)
    dwell = np.round(rng.uniform(8.0, 60.0, n), 1)
    return {"v_V": v, "dwell_s": dwell, "readings": int(readings)}


def session(seed: int = 0, readings: int = 8) -> list[dict]:
    """An identification run and a check run, as the harness runs them."""
    return [identification_run(readings), check_run(seed, readings=readings)]


def shortened(schedules: list[dict], n: int) -> list[dict]:
    """The first ``n`` set-points of every run (quick tests)."""
    return [{"v_V": s["v_V"][:n], "dwell_s": s["dwell_s"][:n], "readings": s["readings"]}
            for s in schedules]
