"""The lab's logger and the session's time line.

Logger convention (see README): after the heater's set-point is written (time
``a``), the logger waits the scheduled dwell, then a trigger latency, then takes
``K`` PSD samples at a fixed sample interval and records their average, stamped at
the middle of the burst.  Writing the log line and the next DAC command costs a
fixed overhead; then the next set-point is applied.  The log holds ``t_s`` (the
burst's mid time, from the run's start), ``v_V`` and ``y_um``; it does *not*
write the dwell.  Between two runs the heater sits at 0 V for ``GAP_S``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: From the end of the dwell to the burst's first sample (s).
LATENCY_S = 0.05
#: PSD sample interval inside a burst (s).
SAMPLE_S = 0.02
#: Writing the log line and the next DAC command (s), after the burst.
OVERHEAD_S = 0.25
#: The heater is off between two runs of a session (s).
GAP_S = 600.0


@dataclass
class Timeline:
    """The session as segments: one per set-point, plus an unrecorded 0 V segment per gap.

    Times are session-absolute (s).  ``a``: the set-point is applied; ``r``: the
    (mid-burst) reading; ``nxt``: the next segment starts.  ``run``: the run of a
    recorded segment (-1 for a gap); ``fresh``: the run starts here (its film in
    negative saturation); ``t_run``: the reading's time from the run's start.
    """

    v: np.ndarray
    a: np.ndarray
    r: np.ndarray
    nxt: np.ndarray
    run: np.ndarray
    fresh: np.ndarray
    t_run: np.ndarray

    @property
    def end_s(self) -> float:
        return float(self.nxt[-1])


def build(schedules: list[dict]) -> Timeline:
    """The session's time line from the runs' schedules, in order."""
    v, a, r, nxt, run, fresh, t_run = [], [], [], [], [], [], []
    clock = 0.0
    for k, sched in enumerate(schedules):
        volts = np.asarray(sched["v_V"], dtype=float)
        dwell = np.asarray(sched["dwell_s"], dtype=float)
        readings = max(int(sched.get("readings", 1)), 1)
        burst_mid = LATENCY_S + SAMPLE_S * (readings - 1) / 2.0
        cycle = LATENCY_S + SAMPLE_S * readings + OVERHEAD_S
        start = clock
        for n in range(volts.size):
            a.append(clock)
            r.append(clock + dwell[n] + burst_mid)
            clock = clock + dwell[n] + cycle
            nxt.append(clock)
            v.append(volts[n])
            run.append(k)
            fresh.append(n == 0)
            t_run.append(r[-1] - start)
        if k + 1 < len(schedules):
            a.append(clock)
            clock = clock + GAP_S
            r.append(clock)
            nxt.append(clock)
            v.append(0.0)
            run.append(-1)
            fresh.append(False)
            t_run.append(np.nan)
    return Timeline(
        v=np.array(v, dtype=float), a=np.array(a), r=np.array(r), nxt=np.array(nxt),
        run=np.array(run, dtype=int), fresh=np.array(fresh, dtype=bool), t_run=np.array(t_run),
    )
