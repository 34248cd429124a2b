"""The small interfaces between the rig and everything that drives it.

The acquisition sequencer knows a heater output, a deflection sensor and a
clock -- not Modbus, not a serial line, not the simulator.  Each protocol is
runtime-checkable (``isinstance(x, HeaterOutput)``) and holds one or two
methods whose docstring says exactly what they mean and in which units.

Backends usually subclass :class:`drivers.channels.GuardedHeater` and
:class:`drivers.channels.PSDSensor`, which implement these protocols and put
the safety checks and retries in one place.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Protocol, runtime_checkable


@dataclass(frozen=True)
class VoltageWindow:
    """The set-points a heater accepts: ``min_V <= v <= max_V`` (V).

    This is the *effective* window: the configured voltage range narrowed by
    the heater-current limit (see :mod:`drivers.limits`).
    """

    min_V: float
    max_V: float

    def __contains__(self, volts: object) -> bool:
        return isinstance(volts, numbers.Real) and self.min_V <= volts <= self.max_V


@dataclass(frozen=True)
class Calibration:
    """The PSD calibration: ``deflection_um = (psd_V - offset_V) * um_per_V``.

    The PSD voltage is linear in the laser spot position (paper section
    5.1); ``um_per_V`` comes from the CCD-camera calibration of the bench.
    """

    um_per_V: float
    offset_V: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.um_per_V) and self.um_per_V != 0):
            raise ValueError(f"um_per_V must be finite and non-zero, got {self.um_per_V}")
        if not math.isfinite(self.offset_V):
            raise ValueError(f"offset_V must be finite, got {self.offset_V}")

    def to_um(self, psd_V: float) -> float:
        """Deflection (um) of a PSD voltage (V)."""
        return (psd_V - self.offset_V) * self.um_per_V

    def to_psd_V(self, deflection_um: float) -> float:
        """PSD voltage (V) of a deflection (um); the inverse of :meth:`to_um`."""
        return deflection_um / self.um_per_V + self.offset_V


@dataclass(frozen=True)
class Reading:
    """One deflection reading: the raw PSD voltage and what it means.

    ``deflection_um`` is ``calibration.to_um(psd_V)``; both are kept so a
    session can be re-calibrated offline.  ``retried``: getting it took more
    than one request -- a NaN or saturated value, a reply that did not answer
    the request, a timeout or a dropped link came first (a sample measured
    with it is flagged ``READ_RETRIED``).
    """

    deflection_um: float
    psd_V: float
    calibration: Calibration
    retried: bool = False


@dataclass(frozen=True)
class SafeState:
    """What is *known* about the heater after it was asked to go to 0 V, the safe state.

    ``confirmed`` only when a 0 V write was acknowledged by the instrument
    and the output, read back, is 0 V: only then may anything say "heater
    at 0 V".  Otherwise ``problem`` says what failed, and ``last_V`` is the
    last set-point the instrument acknowledged (V; ``None`` if none) --
    what a dead or hung instrument keeps driving -- and ``unacknowledged_V``
    a later non-zero set-point that was sent but never acknowledged (it may
    have arrived).
    """

    confirmed: bool
    acknowledged: bool
    readback_V: float | None
    last_V: float | None
    problem: str = ""
    unacknowledged_V: float | None = None

    def describe(self) -> str:
        """One clause for messages and the session log: the fact, or plainly that it is unknown -- led by what
        was read back when the output answered with another value than 0 V."""
        if self.confirmed:
            return "heater at 0 V (0 V written and read back)"
        if self.readback_V is not None:
            return (f"heater NOT at 0 V: it reads back {self.readback_V:g} V after 0 V was written and "
                    f"acknowledged; switch the heater supply off at the bench and check it ({self.problem})")
        held = []
        if self.last_V is not None:
            held.append(f"{self.last_V:g} V, the last set-point the instrument acknowledged")
        if self.unacknowledged_V is not None and self.unacknowledged_V != self.last_V:
            held.append(f"{self.unacknowledged_V:g} V, sent without acknowledgment")
        holding = f"it may still be at {' or at '.join(held)}" if held else "it may still be on"
        return f"heater state UNKNOWN: {holding}; switch the heater supply off at the bench and check it ({self.problem})"


@runtime_checkable
class HeaterOutput(Protocol):
    """The heater voltage output (the DAQ's analogue output, paper figure 7(b))."""

    @property
    def window(self) -> VoltageWindow:
        """The set-points this output accepts (V), after every configured limit."""
        ...

    @property
    def full_scale_V(self) -> float | None:
        """The instrument's output range (+-V) when it, or the configuration, says; else None."""
        ...

    def check_setpoint(self, volts: float) -> float:
        """The value the instrument would receive for ``volts`` (V), after every rule, without writing.

        Raises :class:`drivers.errors.LimitError` naming the rule that
        refuses it (not finite, range, current -- as asked or as rounded on
        the wire -- or the instrument's full scale): what a plan is checked
        with, point by point, before a run starts.
        """
        ...

    def set_voltage(self, volts: float) -> None:
        """Drive the heater at ``volts`` (V).

        Raises :class:`drivers.errors.LimitError` -- and writes nothing --
        when :meth:`check_setpoint` refuses it.
        """
        ...

    def read_voltage(self) -> float:
        """The set-point the output is actually holding, read back from the instrument (V)."""
        ...

    def verify(self) -> bool:
        """Whether the link to the instrument was re-established since the last call.

        After a reconnection the instrument is checked to be the same one
        (a boot id, where it offers one) still holding the last set-point,
        which is then sent again; if it restarted or lost its output,
        :class:`drivers.errors.ContinuityError` is raised.  The caller marks
        whatever it measured across a reconnection.  Backends without a
        link (the in-process simulator) always answer False.
        """
        ...

    def safe_state(self) -> SafeState:
        """Drive the heater to 0 V and say what is known afterwards (never raises a driver fault).

        The answer is ``confirmed`` only after the instrument acknowledged
        the 0 V write and read back 0 V; what ``rig`` reports about the
        heater rests on it.
        """
        ...


@runtime_checkable
class DeflectionSensor(Protocol):
    """The position-sensitive detector that measures the beam's deflection."""

    @property
    def calibration(self) -> Calibration:
        """How PSD volts map to micrometres."""
        ...

    def read(self) -> Reading:
        """One reading now.

        Raises :class:`drivers.errors.SensorError` when the PSD gives no
        usable value (NaN, saturated) after the configured retries.
        """
        ...


@runtime_checkable
class Clock(Protocol):
    """Time as the rig sees it: real, or virtual so that hours of dwell take no time."""

    def now(self) -> float:
        """Seconds on a monotonic clock (the origin is arbitrary)."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass (s, >= 0)."""
        ...
