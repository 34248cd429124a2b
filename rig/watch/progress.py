"""How far a run is: points, elapsed time, what the plan asks for, and when it should end.

Times are rig-clock seconds as the session records them (``t_s``, from the
first set-point; virtual on the simulated device) except ``wall_elapsed_s``,
which is wall-clock time since the session was created (or last reopened
by a resume).

The *planned rig time* is what the plan's waits add up to: the dwell at
every point that is measured or a reversal, the transit at every other
(see :mod:`rig.acquisition.dwell`; a check run's per-point schedule point by
point).  With ``--settle`` the dwell is at most ``max_s``, so the plan
gives an upper bound (``planned_exact`` false).  Sessions whose dwell
policy the sequencer did not write (imports, other producers) have no
planned time, and their ETA comes from the points' observed pace.

The ETA adds the planned waits of the points still to come and, for each,
the overhead the recorded points took beyond their planned wait (set-point
transaction, readings, recording; the median, so one slow point does not
move it).  With a settle dwell a point still to dwell is counted at what
the dwelt points took so far (their median), the overhead from the transit
points alone.  Without a usable plan: the median time per point so far.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from identify.acquisition_plan import reversal_points
from sessions.records import Event, ExcitationRecord
from sessions.schema import Status


@dataclass(frozen=True)
class Progress:
    """The numbers of the page's status panel (times in s; ``None`` where unknown)."""

    n_applied: int
    n_points: int
    n_measured: int
    n_planned_measured: int
    rig_time_s: float
    planned_rig_time_s: float | None
    planned_exact: bool
    eta_s: float | None
    wall_elapsed_s: float | None

    @property
    def fraction(self) -> float:
        return self.n_applied / self.n_points if self.n_points else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "fraction": self.fraction}


def planned_waits(excitation: ExcitationRecord) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """``(waits, settle, exact)``: the wait the plan gives every point ``(N,)`` (s), which points get
    the dwell (measured or reversal) ``(N,)`` bool, and whether the waits are exact (else upper
    bounds); ``None`` when the session's dwell policy is not one the sequencer writes."""
    from rig.acquisition.dwell import DwellSettings, SettleDwell
    from rig.acquisition.errors import AcquisitionError

    try:
        settings = DwellSettings.from_description(excitation.dwell)
    except AcquisitionError:
        return None
    n = excitation.n_points
    settle = excitation.measure | reversal_points(excitation.inputs)
    exact = not isinstance(settings.dwell, SettleDwell)
    if settings.schedule is not None:
        full = np.asarray(settings.schedule, dtype=float)
    else:
        full = np.full(n, settings.dwell.max_s if not exact else settings.dwell.seconds)
    return np.where(settle, full, settings.transit.seconds), settle, exact


def wall_elapsed(events: tuple[Event, ...], now_unix: float) -> float | None:
    """Wall-clock seconds from the last (re)start of the writer to the final event, or to ``now_unix``
    while the run goes on."""
    starts = [e for e in events if e.event in ("created", "reopened")]
    if not starts:
        return None
    start = starts[-1].t_unix
    ends = [e for e in events if e.status.final and e.t_unix >= start]
    return max(0.0, (ends[0].t_unix if ends else now_unix) - start)


def progress(excitation: ExcitationRecord, samples: np.ndarray, events: tuple[Event, ...],
             writer_alive: bool, now_unix: float | None = None) -> Progress:
    """Progress of a run: ``samples`` the rows recorded so far (:data:`~sessions.schema.SAMPLE_DTYPE`)."""
    now_unix = time.time() if now_unix is None else now_unix
    n, total = int(samples.size), excitation.n_points
    t = samples["t_s"].astype(float)
    rig_time = float(t[-1]) if n and np.isfinite(t[-1]) else 0.0
    plan = planned_waits(excitation)
    status = events[-1].status if events else None
    eta = None
    if status is Status.RUNNING and writer_alive and 0 < n < total and np.all(np.isfinite(t)):
        took = np.diff(t, prepend=0.0)
        if plan is None:
            eta = float(np.median(took)) * (total - n)
        else:
            waits, settle, exact = plan
            known = np.ones(n, bool) if exact else ~settle[:n]  # the points whose wait was the planned one
            extra = np.clip(took - waits[:n], 0.0, None)[known]
            overhead = float(np.median(extra)) if extra.size else 0.0
            rest = waits[n:] + overhead
            if not exact and settle[:n].any():  # a settle dwell: as long as the settled points took so far
                rest = np.where(settle[n:], float(np.median(took[settle[:n]])), rest)
            eta = float(rest.sum())
    return Progress(
        n_applied=n,
        n_points=total,
        n_measured=int(np.count_nonzero(samples["measured"])),
        n_planned_measured=int(np.count_nonzero(excitation.measure)),
        rig_time_s=rig_time,
        planned_rig_time_s=None if plan is None else float(plan[0].sum()),
        planned_exact=plan is not None and plan[2],
        eta_s=eta,
        wall_elapsed_s=wall_elapsed(events, now_unix),
    )
