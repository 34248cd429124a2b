"""The lab's logger: when set-points change, when the PSD burst is read, what is written.

Our logger (README.md, "Logger"):

* The run's clock starts when its first set-point is applied.
* Set-point ``n`` is applied at ``T[n]``; the heater holds it for ``dwell_s[n]``
  plus a small software latency (2-30 ms, random); then the PSD is read ``K``
  times at 100 Hz (no longer than 0.5 s in all) and the mean is written.
* ``t_s[n]`` is the middle of the burst, ``dwell_s`` (written) is
  ``t_s[n] - T[n]``: the time from the set-point change to the reading.
* After the burst, 20-60 ms of book-keeping, and the next set-point is applied.
* Between runs the heater is off for 600 s +- 10 % (random, per run).

All timing jitter comes from the run's own ``timing`` stream; the noise from
its own ``noise`` stream.  Neither depends on the effects present.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .streams import stream

READ_RATE_HZ = 100.0
MAX_BURST_S = 0.5
GAP_S = 600.0


@dataclass(frozen=True)
class RunClock:
    change_s: np.ndarray    # T[n]: set-point changes (s from the run's start)
    read_s: np.ndarray      # t_s[n]: the (mid-burst) reading times
    next_s: np.ndarray      # when set-point n is left (T[n+1]; for the last, the run's end)
    gap_before_s: float     # heater-off time before this run (after the previous run's end)

    @property
    def dwell_logged_s(self) -> np.ndarray:
        return self.read_s - self.change_s


def run_clock(seed: int, run: int, dwell_s: np.ndarray, readings: int) -> RunClock:
    dwell = np.asarray(dwell_s, dtype=float)
    n = dwell.size
    rng = stream(seed, run, "timing")
    latency = rng.uniform(0.002, 0.030, n)
    bookkeeping = rng.uniform(0.020, 0.060, n)
    gap = GAP_S * float(rng.uniform(0.9, 1.1))
    burst = min(max(int(readings), 1) / READ_RATE_HZ, MAX_BURST_S)
    held = dwell + latency + burst + bookkeeping
    change = np.concatenate([[0.0], np.cumsum(held)[:-1]]) if n else np.zeros(0)
    read = change + dwell + latency + 0.5 * burst
    return RunClock(change_s=change, read_s=read, next_s=change + held, gap_before_s=gap if run > 0 else np.inf)


def noise(seed: int, run: int, n: int, noise_um: float | None) -> np.ndarray:
    """Gaussian noise of one recorded point (the mean of the burst), rms ``noise_um``."""
    z = stream(seed, run, "noise").standard_normal(n)
    return np.zeros(n) if noise_um is None else float(noise_um) * z


def record(clock: RunClock, v_V: np.ndarray, y_um: np.ndarray) -> dict:
    return {"t_s": clock.read_s.copy(), "v_V": np.asarray(v_V, dtype=float).copy(),
            "y_um": np.asarray(y_um, dtype=float), "dwell_s": clock.dwell_logged_s}
