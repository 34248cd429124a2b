"""Set-points that depend on what was measured: the small interface the sequencer calls while tracking.

An acquisition applies the planned inputs as they are.  A tracking run
(``rig track``) decides each set-point just before applying it -- the
inverse of a model from its memory state, corrected by feedback from the
deflections measured so far -- so the sequencer asks a
:class:`SetpointSource` for it, and tells it what was measured.  The
sequencer keeps every guarantee of a run (safety, dwell, pause, resume,
one flushed row per point); the source knows nothing of the rig.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable


@runtime_checkable
class SetpointSource(Protocol):
    """Decides the set-point of each point of a plan, and what is recorded with it beside the standard columns."""

    def setpoint(self, k: int, t_s: float, dwell_s: float) -> float:
        """The set-point (V) of point ``k``, applied now: ``t_s`` (s) since the start of the run, readings
        after ``dwell_s`` (s).  It must lie in the heater's window."""

    def dwell_for(self, k: int) -> float | None:
        """The wait (s) point ``k`` asks for, asked right after :meth:`setpoint`; None: the run's own dwell
        (a run to a target lengthens its dwell as it finds the points were not at rest)."""

    def measured(self, k: int, v: float, t_s: float, dwell_s: float, deflection_um: float) -> dict[str, float]:
        """Point ``k`` was applied at ``v`` (V), read at ``t_s`` (s) after ``dwell_s`` (s) as ``deflection_um``
        (um; NaN when not measured).  Returns the extra columns to record with it (by name)."""

    def finished(self, k: int, t_s: float) -> bool:
        """Whether the run ends before point ``k`` (``t_s`` s since its start): a run that decides its own
        length (``rig acquire --target-nrmse``) ends complete with fewer points than planned."""
