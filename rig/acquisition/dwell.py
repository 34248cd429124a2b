"""How long to wait at a set-point before measuring: dwell policies and settle conditions.

The paper waits a long, fixed time before every measurement because the
beam's thermal dynamics are slow (quasi-static hysteresis).  Here that is
one policy among small, separately testable objects, in the spirit of
bluesky's suspenders:

* a :class:`SettleCondition` watches the deflection and says whether the
  beam is at rest (:class:`RateBelow`: the rate of change of the deflection
  is below a threshold for a few polls in a row);
* a :class:`DwellPolicy` waits at a set-point: :class:`FixedDwell` (the
  paper's wait), :class:`SettleDwell` (until a condition holds, at most
  ``max_s``), :class:`Transit` (the short pass through a point that is
  neither measured nor a reversal, see :mod:`identify.acquisition_plan`).

Every wait is cut into slices of at most ``slice_s`` so that a pause
request (Ctrl-C) is noticed within a fraction of a second on a real clock;
the policy then returns ``None`` and the sequencer decides what happens.
Policies describe themselves as a JSON-friendly dict (stored in the
session as the excitation's ``dwell``) and :func:`dwell_from_description`
rebuilds them from it, so a resumed session waits as the original did.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

from drivers.protocols import Clock, DeflectionSensor

from .errors import AcquisitionError

#: Longest single sleep while waiting (s): how quickly a pause request is noticed.
SLICE_S = 0.25


@dataclass(frozen=True)
class DwellOutcome:
    """What happened at a set-point: ``waited_s`` (s) and whether the policy's condition was met."""

    waited_s: float
    settled: bool
    timed_out: bool = False


class Averaged(NamedTuple):
    """The mean deflection (um) and PSD voltage (V) of readings taken back to back; ``retried``: one of
    them needed a second request (see :attr:`drivers.protocols.Reading.retried`)."""

    deflection_um: float
    psd_V: float
    retried: bool


def average_reading(sensor: DeflectionSensor, k: int) -> Averaged:
    """The mean of ``k`` readings taken back to back."""
    d = p = 0.0
    retried = False
    for _ in range(k):
        r = sensor.read()
        d += r.deflection_um
        p += r.psd_V
        retried |= r.retried
    return Averaged(d / k, p / k, retried)


def sleep_until(clock: Clock, deadline: float, stop: Callable[[], bool], slice_s: float = SLICE_S) -> bool:
    """Sleep on ``clock`` until ``deadline`` (clock time, s); False if ``stop()`` became true first.

    The wait is cut into slices of ``slice_s`` so that ``stop`` is checked
    often in real time.  A clock whose slice passes in less than half of it
    in real time is simulated (a virtual clock: an hour is one addition);
    there is nothing to gain from slicing it, so the rest is one sleep.
    """
    while True:
        left = deadline - clock.now()
        if left <= 0:
            return True  # done: a pause requested meanwhile waits for the next safe point
        if stop():
            return False
        step = min(left, slice_s)
        t0 = time.monotonic()
        clock.sleep(step)
        if time.monotonic() - t0 < step / 2:
            slice_s = math.inf


# ---------------------------------------------------------------- settle conditions
class SettleCondition(Protocol):
    """Watches successive deflection values at one set-point and says when the beam is at rest."""

    def reset(self) -> None:
        """Forget everything: a new set-point was applied."""

    def observe(self, t_s: float, deflection_um: float) -> None:
        """A new (averaged) deflection ``deflection_um`` (um) at clock time ``t_s`` (s)."""

    @property
    def met(self) -> bool:
        """The beam is at rest by this condition."""

    def describe(self) -> dict[str, Any]:
        """The condition's settings (JSON-friendly)."""


class RateBelow:
    """Settled when ``|d deflection / dt|`` stays below ``rate_um_per_s`` for ``polls`` successive polls.

    The rate is the difference of two successive averaged readings over
    the time between them.  Requiring it twice in a row keeps one lucky
    noisy pair from ending a dwell early.
    """

    def __init__(self, rate_um_per_s: float, polls: int = 2) -> None:
        if not (math.isfinite(rate_um_per_s) and rate_um_per_s > 0):
            raise AcquisitionError(f"settle rate must be a positive number of um/s, got {rate_um_per_s}")
        if polls < 1:
            raise AcquisitionError(f"settle polls must be >= 1, got {polls}")
        self.rate_um_per_s = float(rate_um_per_s)
        self.polls = int(polls)
        self.reset()

    def reset(self) -> None:
        self._last: tuple[float, float] | None = None
        self._quiet = 0
        #: The last rate seen (um/s), NaN before two readings.
        self.rate = math.nan

    def observe(self, t_s: float, deflection_um: float) -> None:
        if self._last is not None and t_s > self._last[0]:
            self.rate = abs(deflection_um - self._last[1]) / (t_s - self._last[0])
            self._quiet = self._quiet + 1 if self.rate < self.rate_um_per_s else 0
        self._last = (t_s, deflection_um)

    @property
    def met(self) -> bool:
        return self._quiet >= self.polls

    def describe(self) -> dict[str, Any]:
        return {"condition": "rate_below", "rate_um_per_s": self.rate_um_per_s, "polls": self.polls}


# ---------------------------------------------------------------- dwell policies
class DwellPolicy(Protocol):
    """Waits at the set-point just applied."""

    def wait(self, clock: Clock, sensor: DeflectionSensor, stop: Callable[[], bool]) -> DwellOutcome | None:
        """Wait; ``None`` when ``stop()`` became true before the end (a pause was requested)."""

    def describe(self) -> dict[str, Any]:
        """The policy's settings (JSON-friendly; :func:`dwell_from_description` reads them back)."""


@dataclass(frozen=True)
class FixedDwell:
    """Wait exactly ``seconds`` (the paper's quasi-static wait); the condition is the time itself."""

    seconds: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds >= 0):
            raise AcquisitionError(f"dwell must be a finite number of seconds >= 0, got {self.seconds}")

    def wait(self, clock: Clock, sensor: DeflectionSensor, stop: Callable[[], bool]) -> DwellOutcome | None:
        t0 = clock.now()
        if not sleep_until(clock, t0 + self.seconds, stop):
            return None
        return DwellOutcome(clock.now() - t0, True)

    def describe(self) -> dict[str, Any]:
        return {"policy": "fixed", "seconds": self.seconds}


@dataclass(frozen=True)
class Transit(FixedDwell):
    """Pass through a point that needs no rest: wait ``seconds`` (often 0) and do not claim it settled."""

    def wait(self, clock: Clock, sensor: DeflectionSensor, stop: Callable[[], bool]) -> DwellOutcome | None:
        out = super().wait(clock, sensor, stop)
        return None if out is None else DwellOutcome(out.waited_s, False)

    def describe(self) -> dict[str, Any]:
        return {"policy": "transit", "seconds": self.seconds}


class SettleDwell:
    """Wait until ``condition`` holds, polling every ``poll_s`` with ``readings``-averaged deflections; at most ``max_s``.

    The outcome is ``settled`` when the condition held, ``timed_out`` when
    ``max_s`` passed first (the point is still measured, and flagged).
    """

    def __init__(self, condition: SettleCondition, max_s: float, poll_s: float = 0.5, readings: int = 4) -> None:
        if not (math.isfinite(max_s) and max_s > 0):
            raise AcquisitionError(f"maximum dwell must be a positive number of seconds, got {max_s}")
        if not (math.isfinite(poll_s) and poll_s > 0):
            raise AcquisitionError(f"poll interval must be a positive number of seconds, got {poll_s}")
        if readings < 1:
            raise AcquisitionError(f"readings per poll must be >= 1, got {readings}")
        self.condition = condition
        self.max_s = float(max_s)
        self.poll_s = float(poll_s)
        self.readings = int(readings)

    def wait(self, clock: Clock, sensor: DeflectionSensor, stop: Callable[[], bool]) -> DwellOutcome | None:
        cond = self.condition
        cond.reset()
        t0 = clock.now()
        end = t0 + self.max_s
        while True:
            cond.observe(clock.now(), average_reading(sensor, self.readings).deflection_um)
            if cond.met:
                return DwellOutcome(clock.now() - t0, True)
            now = clock.now()
            if now >= end:
                return DwellOutcome(now - t0, False, timed_out=True)
            if not sleep_until(clock, min(now + self.poll_s, end), stop):
                return None

    def describe(self) -> dict[str, Any]:
        return {"policy": "settle", "max_s": self.max_s, "poll_s": self.poll_s, **self.condition.describe()}


@dataclass(frozen=True)
class DwellSettings:
    """Everything about waiting and reading in a run (stored in the session as the excitation's ``dwell``).

    ``dwell`` waits at every point that is measured or a reversal (and at
    negative saturation before the run); ``transit`` at every other point;
    ``readings`` readings are averaged per measurement.  ``schedule``
    (seconds, one per point of the plan) replaces a fixed ``dwell`` point by
    point -- a check run's several dwell times; the saturation before the
    run still waits ``dwell``.
    """

    dwell: DwellPolicy
    transit: Transit = Transit(0.0)
    readings: int = 4
    schedule: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.readings, bool) or not isinstance(self.readings, int) or self.readings < 1:
            raise AcquisitionError(f"readings per measurement must be an integer >= 1, got {self.readings}")
        if self.schedule is not None:
            if not isinstance(self.dwell, FixedDwell):
                raise AcquisitionError("per-point dwell times are fixed waits; they cannot be combined with --settle")
            values = tuple(float(x) for x in self.schedule)
            bad = [k for k, x in enumerate(values) if not (math.isfinite(x) and x >= 0)]
            if bad:
                raise AcquisitionError(f"dwell of point {bad[0]} must be a finite number of seconds >= 0, "
                                       f"got {values[bad[0]]}")
            object.__setattr__(self, "schedule", values)

    def at(self, k: int) -> DwellPolicy:
        """The dwell policy of point ``k`` (the schedule's fixed wait, when there is one)."""
        return self.dwell if self.schedule is None else FixedDwell(self.schedule[k])

    def describe(self) -> dict[str, Any]:
        out = {**self.dwell.describe(), "transit_s": self.transit.seconds, "readings": self.readings}
        if self.schedule is not None:
            out["schedule_s"] = list(self.schedule)
        return out

    @classmethod
    def from_description(cls, d: dict[str, Any]) -> "DwellSettings":
        """The settings a :meth:`describe` dict stands for; :class:`AcquisitionError` if it is not one of ours."""
        policy = d.get("policy") if isinstance(d, dict) else None
        try:
            readings = int(d.get("readings", 4))
            transit = Transit(float(d.get("transit_s", 0.0)))
            if policy == "fixed":
                schedule = d.get("schedule_s")
                return cls(FixedDwell(float(d["seconds"])), transit, readings,
                           None if schedule is None else tuple(float(x) for x in schedule))
            if policy == "settle" and d.get("condition") == "rate_below":
                cond = RateBelow(float(d["rate_um_per_s"]), int(d.get("polls", 2)))
                return cls(SettleDwell(cond, float(d["max_s"]), float(d["poll_s"]), readings), transit, readings)
        except (KeyError, TypeError, ValueError) as exc:
            raise AcquisitionError(f"malformed dwell policy {d!r} ({exc})") from None
        raise AcquisitionError(f"dwell policy {policy!r} was not written by 'rig acquire'; cannot resume it")
