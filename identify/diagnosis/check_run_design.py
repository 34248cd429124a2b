"""The check-run input design: a different input family from the identification run.

The damped oscillation steps one wall at a time with one long dwell, and
the base fit on it is (nearly) interpolating, so several effects are
absorbed there and only show on other inputs.  A check run therefore
varies what the identification run holds fixed:

* **random reversals** -- turning points drawn uniformly over the range,
  so minor loops of every size and nesting appear (creep, memory);
* **several step sizes** -- each monotone leg between two turning points is
  cut into 1 to ``max_steps`` steps at random fractions, from a few
  millivolts to the whole range (thermal lag grows with the step);
* **several dwell times** -- every point's dwell is drawn from
  ``dwells_s`` (lag decays with the dwell; creep with the time since the
  reversal, which the dwells spread out);
* **repeated set-points** -- a fraction of the points is applied twice in a
  row with a new dwell: the memory state is the same, so the difference is
  noise (and whatever moves while the heater is held), which gives the
  noise floor without a second run.

All inputs stay on ``[v_min, v_max]`` (the identification range), rounded
to 0.1 mV.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import IdentifyError

#: Default dwell choices (s): all much longer than the simulated beam's 0.5 s time constant.
DWELLS_S = (8.0, 15.0, 30.0, 60.0)


@dataclass(frozen=True)
class CheckDesign:
    """Set-points ``inputs`` (V) and per-point ``dwell_s`` (s), shape ``(n,)`` each."""

    inputs: np.ndarray
    dwell_s: np.ndarray

    @property
    def duration_s(self) -> float:
        return float(self.dwell_s.sum())


def check_design(
    v_min: float,
    v_max: float,
    n_points: int = 200,
    *,
    dwells_s: tuple[float, ...] = DWELLS_S,
    max_steps: int = 5,
    repeat_fraction: float = 0.15,
    seed: int | None = 0,
) -> CheckDesign:
    """A check run of ``n_points`` points on ``[v_min, v_max]`` (see the module doc)."""
    if not v_max > v_min:
        raise IdentifyError(f"the check range needs v_max > v_min, got [{v_min}, {v_max}]")
    if n_points < 2:
        raise IdentifyError(f"a check run needs at least 2 points, got {n_points}")
    if not dwells_s or min(dwells_s) < 0:
        raise IdentifyError("dwell choices must be non-negative seconds")
    if max_steps < 1 or not 0 <= repeat_fraction < 1:
        raise IdentifyError("max_steps must be >= 1 and repeat_fraction in [0, 1)")
    rng = np.random.default_rng(seed)
    span = v_max - v_min
    inputs: list[float] = []
    pos, up = v_min, True
    while len(inputs) < n_points:
        lo, hi = (pos + 0.05 * span, v_max) if up else (v_min, pos - 0.05 * span)
        if hi <= lo:
            up = not up
            continue
        target = rng.uniform(lo, hi)
        steps = int(rng.integers(1, max_steps + 1))
        cuts = np.cumsum(rng.dirichlet(np.ones(steps)))
        for x in pos + (target - pos) * cuts:
            inputs.append(float(x))
            if rng.random() < repeat_fraction:
                inputs.append(float(x))
        pos, up = target, not up
    v = np.clip(np.round(np.asarray(inputs[:n_points]), 4), v_min, v_max)
    dwell = rng.choice(np.asarray(dwells_s, dtype=float), size=v.size)
    return CheckDesign(v, dwell)
