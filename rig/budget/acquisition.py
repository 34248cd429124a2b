"""What a ``rig acquire`` plan costs: points, rig time at the configured dwell, file size and memory.

The limits (docs/reference/limits.md), beyond which the plan is refused
unless ``--yes``:

* :data:`MAX_POINTS` applied points: checked from the options alone, before
  the plan is built (``--levels 10000`` is a 50-million-point damped
  oscillation: 12 GB to build, 3 GB of session, 31 years at 20 s a point);
* :data:`MAX_REAL_RIG_TIME_S` of rig time on a real clock (on the virtual
  clock of the simulated device rig time costs nothing; its wall time is
  about :data:`VIRTUAL_WALL_S_PER_POINT` per point).

The per-point figures were measured on the 2-core development machine
(``rig acquire --levels 30/300/600`` on the simulated device: 467, 45,452 and
180,902 points; session 50 kB, 2.9 MB, 11.4 MB; peak memory 84, 98 and
130 MB; 0.4 ms per point on a quiet machine, 1.2-1.4 ms under load).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import Exceeded, format_bytes, format_duration

#: Most applied points a plan may have without --yes.
MAX_POINTS = 1_000_000
#: Longest rig time on a real clock without --yes (s): a week.
MAX_REAL_RIG_TIME_S = 7 * 86400.0
#: Session file bytes per applied point (the sample row, its chunk share, the plan's columns).
SESSION_BYTES_PER_POINT = 64
#: A session file's size before its first sample (attributes, log, empty datasets).
SESSION_BASE_BYTES = 20e3
#: Peak memory per applied point beyond the program itself (the plan, its flags, the sequencer's arrays).
MEMORY_BYTES_PER_POINT = 240
#: The program's own resident memory (interpreter, numpy, h5py, the drivers), about.
BASE_MEMORY_BYTES = 85e6
#: Wall time per point on the virtual clock, quiet machine (s).
VIRTUAL_WALL_S_PER_POINT = 0.0005


def planned_points(sequence: str, levels: int | None, points: int | None, thermal_term: bool,
                   default_levels: int, default_points: int) -> int | None:
    """How many points the options ask for, without building the plan (None: a set-point file's rows)."""
    extra = default_points if points is None else points
    if sequence in ("damped", "damped+check"):
        big_l = default_levels if levels is None else levels
        if big_l < 1:
            return None  # the plan's own check says what is wrong
        damped = big_l * (big_l + 1) // 2 + 1 + int(thermal_term)
        return damped + (extra if sequence == "damped+check" else 0)
    if sequence in ("random", "check"):
        return extra
    return None


def too_many_points(n: int | None) -> list[Exceeded]:
    """The point-count limit, checked before a plan of ``n`` points is built."""
    if n is not None and n > MAX_POINTS:
        return [Exceeded("the plan has", f"{n:,} points", f"{MAX_POINTS:,}")]
    return []


@dataclass(frozen=True)
class AcquisitionCost:
    """A plan's size and cost: ``rig_time_s`` with every dwell at its longest (``--settle`` may end sooner)."""

    points: int
    measured: int
    reversals: int
    rig_time_s: float
    settle: bool
    virtual_clock: bool
    session_bytes: float
    memory_bytes: float

    @property
    def wall_s(self) -> float:
        """Wall time: the rig time on a real clock, the sequencer's per-point cost on the virtual one."""
        return self.points * VIRTUAL_WALL_S_PER_POINT if self.virtual_clock else self.rig_time_s

    def describe(self) -> str:
        """One line for the operator, before anything is applied."""
        at_most = "at most " if self.settle else ""
        clock = (f"virtual clock: about {format_duration(self.wall_s)} of wall time" if self.virtual_clock
                 else "real clock")
        return (f"plan: {self.points:,} points ({self.measured:,} measured, {self.reversals:,} reversal points); "
                f"rig time {at_most}{format_duration(self.rig_time_s)} ({clock}); "
                f"session file about {format_bytes(self.session_bytes)}, memory about "
                f"{format_bytes(self.memory_bytes)}")

    def exceeded(self) -> list[Exceeded]:
        """The documented limits this plan is over."""
        out = too_many_points(self.points)
        if not self.virtual_clock and self.rig_time_s > MAX_REAL_RIG_TIME_S:
            out.append(Exceeded("rig time", format_duration(self.rig_time_s), format_duration(MAX_REAL_RIG_TIME_S)))
        return out


def estimate_acquisition(measure: np.ndarray, reversals: np.ndarray, dwell_s: float, transit_s: float,
                         schedule: tuple[float, ...] | None, settle: bool, virtual_clock: bool) -> AcquisitionCost:
    """The cost of a plan whose points are measured where ``measure`` and reversal points where
    ``reversals`` (``(N,)`` bool each).

    Every measured or reversal point waits ``dwell_s`` (or its ``schedule``
    entry), every other point ``transit_s``; negative saturation before the
    run waits ``dwell_s`` too.
    """
    measure, reversals = np.asarray(measure, bool), np.asarray(reversals, bool)
    n = int(measure.size)
    dwell = np.full(n, float(dwell_s)) if schedule is None else np.asarray(schedule, dtype=float)
    waits = np.where(measure | reversals, dwell, float(transit_s))
    return AcquisitionCost(
        points=n,
        measured=int(np.count_nonzero(measure)),
        reversals=int(np.count_nonzero(reversals)),
        rig_time_s=float(dwell_s + waits.sum()),
        settle=settle,
        virtual_clock=virtual_clock,
        session_bytes=float(SESSION_BASE_BYTES + SESSION_BYTES_PER_POINT * n),
        memory_bytes=float(BASE_MEMORY_BYTES + MEMORY_BYTES_PER_POINT * n),
    )


def announce(plan, dwell_s: float, transit_s: float, schedule: tuple[float, ...] | None, settle: bool,
             virtual_clock: bool, yes: bool) -> AcquisitionCost:
    """State ``plan``'s cost on stderr (one line) and refuse it above the limits unless ``yes``.

    ``plan`` is the :class:`rig.acquisition.AcquisitionPlan` about to run.
    """
    import click

    from .limits import refuse_unless_confirmed

    cost = estimate_acquisition(plan.measure, plan.reversals, dwell_s, transit_s, schedule, settle, virtual_clock)
    refuse_unless_confirmed("rig acquire", cost.exceeded(), yes)
    click.echo(cost.describe(), err=True)
    return cost
