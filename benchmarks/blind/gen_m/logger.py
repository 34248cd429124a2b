"""The lab's logger: when each set-point is applied and each reading taken, and the PSD noise.

Timing of one run (all times in s from the run's own start):

* the controller starts the run and applies the first set-point after a short
  start-up latency (0.5 to 2 s);
* set-point ``n`` is applied at ``t_set[n]``, held for ``dwell_s[n]``, then the
  PSD is sampled ``K`` times at 2 ms intervals (a burst of at most 0.4 s); the
  reading's time stamp ``t_s[n]`` is the middle of the burst;
* after the burst the host writes the record and sends the next set-point:
  a latency of 30 to 150 ms, different at every step.

The logger writes ``t_s`` (ms resolution) and ``dwell_s``: the time from the
set-point change to the reading (``t_s - t_set``, ms resolution).

Between two runs the heater is off for 9 to 11.5 minutes.

The timing and the noise of run ``r`` are drawn from streams keyed by ``r``
only, so they do not depend on the effects, nor on the runs that follow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .streams import stream

SAMPLE_INTERVAL_S = 0.002
MAX_BURST_S = 0.4


@dataclass(frozen=True)
class RunTiming:
    """Event times of one run (s), each array ``(n,)``; ``gap_before_s`` the heater-off time before it."""

    t_set: np.ndarray  # set-point applied
    t_read: np.ndarray  # reading (middle of the burst)
    t_next: np.ndarray  # next set-point applied (for the last one: the heater is switched off)
    gap_before_s: float

    @property
    def logged_t_s(self) -> np.ndarray:
        return np.round(self.t_read, 3)

    @property
    def logged_dwell_s(self) -> np.ndarray:
        return np.round(self.t_read - self.t_set, 3)


def run_timing(seed: int, run_index: int, dwell_s: np.ndarray, readings: int) -> RunTiming:
    """The timing of run ``run_index`` with commanded dwells ``dwell_s`` (s) ``(n,)`` and ``readings`` per point."""
    rng = stream(seed, "timing", run_index)
    dwell = np.asarray(dwell_s, dtype=float)
    n = dwell.size
    burst = min(max(int(readings), 1) * SAMPLE_INTERVAL_S, MAX_BURST_S)
    start = float(rng.uniform(0.5, 2.0))
    latency = rng.uniform(0.03, 0.15, size=n)
    gap = float(rng.uniform(540.0, 690.0))
    step = dwell + burst + latency
    t_set = start + np.concatenate([[0.0], np.cumsum(step)[:-1]]) if n else np.zeros(0)
    t_read = t_set + dwell + 0.5 * burst
    t_next = t_set + step
    return RunTiming(t_set=t_set, t_read=t_read, t_next=t_next, gap_before_s=gap if run_index > 0 else np.inf)


def run_noise(seed: int, run_index: int, n: int, noise_um: float | None) -> np.ndarray:
    """Gaussian noise (um) ``(n,)`` of the recorded points of run ``run_index``: rms ``noise_um`` per point."""
    if noise_um is None or noise_um == 0:
        return np.zeros(n)
    return float(noise_um) * stream(seed, "noise", run_index).standard_normal(n)
