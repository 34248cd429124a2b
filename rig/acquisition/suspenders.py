"""Suspenders for the sensor: readings that cannot be measurements, whatever value they carry.

A PSD whose reading is frozen (a dead sensor, a DAQ channel that stopped
converting) or replayed (a gateway answering from a cache) gives plausible
numbers: nothing about one value says it is wrong.  What gives it away is
that a noisy analogue signal never repeats itself to the last bit while the
beam moves.  In the spirit of bluesky's suspenders each check is one small
object with one hook, :meth:`Suspender.objection`, asked about every raw
reading before it is used, and :meth:`Suspender.accept`, told of every
reading that was used:

* :class:`StaleReading` -- per reading: bit-identical to the reading before
  it although the heater moved in between (any sensor whose output depends
  on the input; a noise-free simulated one too);
* :class:`StuckSensor` -- over a window: on a sensor that has shown itself
  noisy (it practically never repeats a value at one set-point), ``window``
  bit-identical readings in a row.

:class:`CheckedSensor` puts them between the sequencer and the sensor: a
reading objected to is read again (``rereads`` times); one that passes then
is used and marked ``retried`` (the sample is flagged ``READ_RETRIED``); one
still objected to fails the run with the objection (:class:`SensorError`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

from drivers.errors import SensorError
from drivers.protocols import Calibration, DeflectionSensor, Reading


class Suspender(Protocol):
    def objection(self, setpoint_V: float, psd_V: float) -> str | None:
        """Why the raw reading ``psd_V`` (V), taken at ``setpoint_V`` (V), cannot be a measurement; None if it can."""

    def accept(self, setpoint_V: float, psd_V: float) -> None:
        """The reading was used."""


class StaleReading:
    """A reading bit-identical to the last one used although the set-point changed since: stale or frozen."""

    def __init__(self) -> None:
        self._last: tuple[float, float] | None = None

    def objection(self, setpoint_V: float, psd_V: float) -> str | None:
        last = self._last
        if last is not None and last[1] == psd_V and last[0] != setpoint_V:
            return (f"the PSD reads {psd_V!r} V, bit-identical to its reading at {last[0]:g} V, although the heater "
                    f"moved to {setpoint_V:g} V: a stale or frozen reading")
        return None

    def accept(self, setpoint_V: float, psd_V: float) -> None:
        self._last = (setpoint_V, psd_V)


class StuckSensor:
    """On a sensor known to be noisy -- at least ``pairs`` successive readings at one set-point, fewer than
    ``repeats`` of them bit-identical -- ``window`` bit-identical readings in a row: the sensor is stuck."""

    def __init__(self, window: int = 4, pairs: int = 20, repeats: float = 0.01) -> None:
        self.window, self.pairs, self.repeats = window, pairs, repeats
        self._last: tuple[float, float] | None = None
        self._run = 1  # readings in a row equal to the last one
        self._seen = self._same = 0  # pairs at one set-point, and how many of them were equal
        self._held = 0  # of those, the equal pairs of the current run (not evidence about the sensor's noise)

    def noisy(self) -> bool:
        seen, same = self._seen - self._held, self._same - self._held
        return seen >= self.pairs and same < self.repeats * seen

    def objection(self, setpoint_V: float, psd_V: float) -> str | None:
        if self.noisy() and self._last is not None and self._last[1] == psd_V and self._run + 1 >= self.window:
            return (f"the PSD has read {psd_V!r} V {self._run + 1} times in a row, bit-identical, where it has "
                    f"otherwise practically never repeated itself: a stuck sensor")
        return None

    def accept(self, setpoint_V: float, psd_V: float) -> None:
        last = self._last
        same = last is not None and last[1] == psd_V
        here = last is not None and last[0] == setpoint_V
        self._seen += here
        self._same += same and here
        self._run, self._held = (self._run + 1, self._held + here) if same else (1, 0)
        self._last = (setpoint_V, psd_V)


class CheckedSensor:
    """The sensor as the sequencer reads it (a :class:`DeflectionSensor`): every reading passes the
    suspenders, or is read again.  ``setpoint_V`` is the set-point applied now (the sequencer sets it)."""

    def __init__(self, sensor: DeflectionSensor, suspenders: tuple[Suspender, ...] | None = None,
                 rereads: int = 3) -> None:
        self.sensor = sensor
        self.suspenders = suspenders if suspenders is not None else (StaleReading(), StuckSensor())
        self.rereads = rereads
        self.setpoint_V = math.nan

    @property
    def calibration(self) -> Calibration:
        return self.sensor.calibration

    def read(self) -> Reading:
        reading = self.sensor.read()
        retried = reading.retried
        for attempt in range(self.rereads + 1):
            why = next((w for s in self.suspenders if (w := s.objection(self.setpoint_V, reading.psd_V))), None)
            if why is None:
                for s in self.suspenders:
                    s.accept(self.setpoint_V, reading.psd_V)
                return dataclasses.replace(reading, retried=retried) if retried != reading.retried else reading
            if attempt == self.rereads:
                raise SensorError(f"{why} (still after {self.rereads} re-reads)")
            reading = self.sensor.read()
            retried = True
        raise AssertionError("unreachable")
