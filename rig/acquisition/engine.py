"""The sequencer: applies a plan point by point through a heater, a sensor and a clock, and records every point.

It knows three protocols from :mod:`drivers.protocols` (``HeaterOutput``,
``DeflectionSensor``, ``Clock``) and a :class:`Recorder` (the session
writer) -- no transport, no simulator, no terminal.  For every point ``k``
of the plan:

1. a safe point: if a pause was requested (Ctrl-C), the heater stays at the
   current set-point and ``on_pause`` decides to resume or abort;
2. the set-point ``v_k`` is applied and read back from the instrument: one
   it acknowledged but does not hold raises
   :class:`~drivers.errors.SetpointNotApplied` before anything is measured
   against it;
3. it waits: the full dwell policy where the point is measured or is a
   reversal point (which must be reached at rest, see
   :mod:`identify.acquisition_plan`), a transit elsewhere; a pause request
   during the wait pauses, and the wait starts again on resume;
4. a measured point averages ``readings`` sensor readings, each checked by
   the suspenders of :mod:`~rig.acquisition.suspenders` (a stale or stuck
   PSD is read again, and fails the run when it persists); a point whose
   reading needed a second request is flagged ``READ_RETRIED``;
5. the link is checked (:meth:`~drivers.protocols.HeaterOutput.verify`):
   if it was re-established meanwhile, the instrument was found to be the
   same one still holding the set-point (which was sent again), and the
   row is flagged ``RECONNECTED`` and a ``reconnected`` event logged; an
   instrument that restarted or lost its output raises
   :class:`~drivers.errors.ContinuityError` and nothing is recorded for
   the point -- the beam's memory state is gone, the run must stop;
6. the row is appended to the session and flushed before the next point
   (:meth:`sessions.SessionWriter.append`): every applied point gets one,
   unmeasured ones with output NaN.

A tracking run (``rig track``) gives the sequencer a
:class:`~rig.acquisition.setpoint_source.SetpointSource`: step 2 then applies the
set-point it computes from the memory state and the measurements so far
(instead of the plan's input), and step 6 records the extra columns it
returns with the row.

``t_s`` is the time on the rig's clock since the first set-point of the
run; ``dwell_s`` is the time from applying the set-point to the start of
its readings (pauses included: the heater was held at the set-point).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from drivers.errors import SetpointNotApplied
from drivers.protocols import Clock, DeflectionSensor, HeaterOutput
from drivers.setpoint_rules import same_setpoint
from sessions import SampleFlag

from .dwell import DwellOutcome, DwellPolicy, DwellSettings, FixedDwell, average_reading
from .interrupt import Aborted, Decision, PauseInfo, PauseSwitch
from .plan import AcquisitionPlan
from .setpoint_source import SetpointSource
from .suspenders import CheckedSensor

#: The set-point of negative saturation: heater off, the beam at ambient, below the whole transition.
SATURATION_V = 0.0


class Recorder(Protocol):
    """Where the sequencer writes: :class:`sessions.SessionWriter` satisfies it."""

    def append(self, t_s: float, input: float, output: float = math.nan, *, raw: float = math.nan,
               dwell_s: float = math.nan, settled: bool = False, measured: bool = True, flags: int = 0,
               extra: dict[str, float] | None = None) -> int: ...

    def log(self, event: str, message: str = "") -> None: ...


@dataclass(frozen=True)
class PointResult:
    """One applied point as recorded: times in s, input in V, deflection in um, PSD in V (NaN if not measured)."""

    index: int
    t_s: float
    input_V: float
    deflection_um: float
    psd_V: float
    dwell_s: float
    settled: bool
    measured: bool
    flags: int


@dataclass(frozen=True)
class ReplayReport:
    """How a memory state was restored: points replayed, of which settled, and the rig time it took (s)."""

    points: int
    settled: int
    seconds: float


class Sequencer:
    """Drives one run.  ``on_sample(result)`` is called after each point is on disk (progress bars).

    ``pause`` is the Ctrl-C switch (None: no pausing, Ctrl-C aborts at once);
    ``on_pause(info)`` answers ``"resume"`` or ``"abort"`` (default: abort).
    ``setpoints`` (a tracking run) decides each point's set-point when it is
    applied instead of the plan's input, and what is recorded with it.
    """

    def __init__(
        self,
        heater: HeaterOutput,
        sensor: DeflectionSensor,
        clock: Clock,
        plan: AcquisitionPlan,
        settings: DwellSettings,
        recorder: Recorder,
        *,
        pause: PauseSwitch | None = None,
        on_pause: Callable[[PauseInfo], Decision] | None = None,
        on_sample: Callable[[PointResult], None] | None = None,
        setpoints: SetpointSource | None = None,
    ) -> None:
        self.heater = heater
        self.sensor = CheckedSensor(sensor)
        self.clock = clock
        self.plan = plan
        self.settings = settings
        self.recorder = recorder
        self.pause = pause
        self.on_pause = on_pause
        self.on_sample = on_sample
        self.setpoints = setpoints
        self._setpoint = math.nan

    # ------------------------------------------------------------ pausing
    def _pause_requested(self) -> bool:
        return self.pause is not None and self.pause.requested

    def _pause(self, k: int, phase: str) -> None:
        """Hold the heater where it is and ask whether to go on; raises :class:`Aborted` to stop."""
        n = self.plan.n_points
        info = PauseInfo(k, n, self._setpoint, phase)
        held = "nothing applied yet" if math.isnan(self._setpoint) else f"heater held at {self._setpoint:g} V"
        self.recorder.log("paused", f"Ctrl-C at point {k} of {n} ({phase}); {held}")
        decision = self.on_pause(info) if self.on_pause is not None else "abort"
        assert self.pause is not None
        if decision != "resume":
            raise self.pause.abort(f"aborted by the operator at point {k} of {n}")
        self.pause.clear()
        self.recorder.log("continued", f"resumed by the operator at point {k} ({phase})")

    def _checkpoint(self, k: int, phase: str) -> None:
        if self._pause_requested():
            self._pause(k, phase)

    # ------------------------------------------------------------ one point
    def _wait(self, policy: DwellPolicy, k: int, phase: str) -> DwellOutcome:
        """Wait by ``policy`` at the current set-point; pauses restart the wait."""
        t_set = self.clock.now()
        while True:
            out = policy.wait(self.clock, self.sensor, self._pause_requested)
            if out is not None:
                return DwellOutcome(self.clock.now() - t_set, out.settled, out.timed_out)
            self._pause(k, phase)

    def _apply(self, k: int, volts: float, settle: bool, phase: str, policy: DwellPolicy | None = None) -> DwellOutcome:
        """Set ``volts`` for point ``k`` and wait by ``policy`` (default: the settings' for the point)."""
        self._checkpoint(k, "before point" if phase == "run" else phase)
        self.heater.set_voltage(volts)
        self._setpoint = self.sensor.setpoint_V = volts
        self._read_back(k, volts, phase)
        s = self.settings
        if policy is None:
            policy = (s.dwell if phase == "saturation" else s.at(k)) if settle else s.transit
        return self._wait(policy, k, "dwell" if phase == "run" else phase)

    def _read_back(self, k: int, volts: float, phase: str) -> None:
        """The instrument must hold the set-point it acknowledged: else nothing may be measured against it."""
        sent = self.heater.check_setpoint(volts)
        back = self.heater.read_voltage()
        if not same_setpoint(back, sent):
            where = f"point {k}" if phase == "run" else f"the {phase} at point {k}"
            raise SetpointNotApplied(
                f"the heater reads back {back:g} V at {where}, where {sent:g} V was written and acknowledged: the "
                "instrument did not apply the set-point (a write dropped on the way, an output in local mode)"
            )

    def _link_checked(self, k: int, phase: str) -> bool:
        """Whether the link was re-established during point ``k`` (checked, set-point re-sent, logged)."""
        if not self.heater.verify():
            return False
        what = f"point {k} (flagged RECONNECTED)" if phase == "run" else f"the {phase} at point {k}"
        self.recorder.log(
            "reconnected",
            f"the link to the instrument dropped and came back during {what}: same instrument, output held at "
            f"{self._setpoint:g} V, set-point sent again",
        )
        return True

    # ------------------------------------------------------------ phases
    def saturate(self) -> tuple[DwellOutcome, float]:
        """Negative saturation: heater at 0 V for a full dwell; returns the wait and the deflection (um) there."""
        out = self._apply(0, SATURATION_V, True, "saturation")
        deflection = average_reading(self.sensor, self.settings.readings).deflection_um
        self._link_checked(0, "saturation")
        self.recorder.log(
            "saturated", f"negative saturation: {SATURATION_V:g} V for {out.waited_s:.6g} s, deflection {deflection:.6g} um"
        )
        return out, deflection

    def replay(self, history: np.ndarray) -> ReplayReport:
        """Re-apply the first ``count`` points, ``history`` (V, ``(count,)``, as recorded), without
        measuring: the dwell at the plan's reversal points and at the last point, a transit elsewhere."""
        t0 = self.clock.now()
        count = len(history)
        reversals = self.plan.reversals
        settled = 0
        for k in range(count):
            settle = bool(reversals[k]) or k == count - 1
            self._apply(k, float(history[k]), settle, "replay")
            self._link_checked(k, "replay")
            settled += settle
        return ReplayReport(count, settled, self.clock.now() - t0)

    def run(self, start: int = 0, elapsed_s: float = 0.0, first_flags: int = 0) -> None:
        """Apply points ``start..N-1`` of the plan and record each one.

        ``elapsed_s`` is the run time already recorded (a resumed session's
        last ``t_s``): ``t_s`` continues from it.  ``first_flags`` are added
        to the first point recorded (``AFTER_RESUME``).
        """
        plan = self.plan
        inputs, measure, settle, flags = plan.inputs, plan.measure, plan.settle, plan.flags
        n = plan.n_points
        readings = self.settings.readings
        t0 = self.clock.now() - elapsed_s
        extra = int(first_flags)
        source = self.setpoints
        for k in range(start, n):
            override = None
            if source is None:
                v = float(inputs[k])
            elif source.finished(k, self.clock.now() - t0):
                self.recorder.log("ended", f"the set-point source ended the run after {k} of {n} planned points")
                break
            else:
                self._checkpoint(k, "before point")
                policy = self.settings.at(k) if settle[k] else self.settings.transit
                v = float(source.setpoint(k, self.clock.now() - t0, getattr(policy, "seconds", math.nan)))
                asked = source.dwell_for(k)
                override = None if asked is None or not settle[k] else FixedDwell(float(asked))
            out = self._apply(k, v, bool(settle[k]), "run", override)
            retried = False
            if measure[k]:
                deflection, psd, retried = average_reading(self.sensor, readings)
            else:
                deflection = psd = math.nan
            f = int(flags[k]) | extra
            if retried:
                f |= SampleFlag.READ_RETRIED
            if out.timed_out:
                f |= SampleFlag.DWELL_TIMEOUT
            if self._link_checked(k, "run"):
                f |= SampleFlag.RECONNECTED
            result = PointResult(k, self.clock.now() - t0, v, deflection, psd, out.waited_s,
                                 out.settled, bool(measure[k]), int(f))
            extra = None if source is None else source.measured(k, v, result.t_s, out.waited_s, deflection)
            self.recorder.append(result.t_s, v, deflection, raw=psd, dwell_s=out.waited_s,
                                 settled=out.settled, measured=result.measured, flags=result.flags,
                                 **({"extra": extra} if extra else {}))
            extra = 0
            if self.on_sample is not None:
                self.on_sample(result)
