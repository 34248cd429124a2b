"""Example schedules of this lab (for the tests and the effect-size table), written from SPEC.md's description.

* identification: a damped oscillation on the grid's walls (nested first-order reversal sweeps with a
  decaying amplitude), 467 set-points, 20 s dwells;
* check: about 360 set-points with random reversals, steps from millivolts to the whole range, dwells of
  8-60 s, some set-points repeated.
"""

from __future__ import annotations

import numpy as np


def identification(levels: int = 30, v_min: float = 0.0, v_max: float = 6.0, n: int = 467) -> dict:
    walls = v_min + (v_max - v_min) * np.arange(levels + 1) / levels
    seq = []
    # damped sawtooth: up to a decaying top wall, then down the staircase of walls below it
    for top in range(levels, 0, -1):
        seq.append(walls[top])
        stairs = list(range(top - 1, -1, -1))
        seq.extend(walls[b] for b in stairs)
    extra = len(seq) - n
    if extra > 0:                                     # drop the bottom (0 V) of the first descents
        drop, out = extra, []
        for i, x in enumerate(seq):
            if drop > 0 and x == walls[0] and i + 1 < len(seq) and i > 0:
                drop -= 1
                continue
            out.append(x)
        seq = out
    v = np.array(seq[:n])
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 10}


def check(seed: int = 0, n: int = 360, v_max: float = 6.0) -> dict:
    rng = np.random.default_rng(seed)
    v = [float(rng.uniform(0.0, v_max))]
    direction = 1.0
    for _ in range(n - 1):
        if rng.random() < 0.12:                      # repeated set-point
            v.append(v[-1])
            continue
        if rng.random() < 0.35:                      # reversal
            direction = -direction
        step = float(np.exp(rng.uniform(np.log(1e-3), np.log(v_max))))
        x = v[-1] + direction * step
        if x < 0.0 or x > v_max:
            direction = -direction
            x = float(np.clip(v[-1] + direction * step, 0.0, v_max))
        v.append(x)
    return {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": 10}


def session(seed: int = 0) -> list[dict]:
    return [identification(), check(seed)]
