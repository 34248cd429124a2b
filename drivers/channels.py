"""Base classes for backends: the checks live in the public methods, once.

Following PyMeasure's adapters, the public :meth:`GuardedHeater.set_voltage`
and :meth:`PSDSensor.read` do the checking, retrying and bookkeeping, then
call the private ``_write_voltage`` / ``_read_psd`` that a transport
(Modbus, serial line, in-process simulator) implements.  A backend cannot
forget a limit: it never sees a value that has not passed them.
"""

from __future__ import annotations

import abc
import math

from interrupts import delay_keyboard_interrupt

from .errors import ContinuityError, DriverError, LimitError, SensorError
from .limits import HeaterLimits
from .protocols import Calibration, Reading, SafeState, VoltageWindow
from .setpoint_rules import SetpointRules, same_setpoint


def _is_zero(volts: float) -> bool:
    return abs(volts) <= 1e-9



class GuardedHeater(abc.ABC):
    """A heater output whose limits are enforced before anything is written.

    Implements :class:`drivers.protocols.HeaterOutput`.  Subclasses provide
    :meth:`_write_voltage` and :meth:`_read_voltage`, and
    :meth:`_on_wire` when the instrument rounds (a scaled integer register,
    a printed decimal): the value it returns is checked against the limits
    too, so rounding can never push a set-point over one (see
    :class:`drivers.setpoint_rules.SetpointRules`, which also holds the
    instrument's full scale where it is known).
    """

    def __init__(self, limits: HeaterLimits, full_scale_V: float | None = None) -> None:
        self.limits = limits
        if 0.0 not in limits.window:
            raise ValueError("the heater limits must allow 0 V (the safe state)")
        #: Every rule a set-point passes, the wire's rounding and the instrument's full scale included.
        self.rules = SetpointRules(limits, lambda v: self._on_wire(v), full_scale_V)
        #: The last set-point the instrument acknowledged (V), or None before the first write.
        self.last_written: float | None = None
        #: A set-point sent whose write raised (V): it may or may not have arrived.
        self.unacknowledged: float | None = None
        self._writes = 0
        self._safe: tuple[int, SafeState] | None = None
        self._epoch: int | None = None  # the link epoch last verified (None: not yet)
        self._identity: object | None = None

    @property
    def window(self) -> VoltageWindow:
        """The set-points accepted (V): the limits, with edges pulled in to what the wire carries."""
        return self.rules.window

    @property
    def full_scale_V(self) -> float | None:
        """The instrument's output range +-V, when it (or the configuration) says; else None."""
        return self.rules.full_scale_V

    def check_setpoint(self, volts: float) -> float:
        """The value the instrument would receive for ``volts`` (V); :class:`LimitError` (nothing written) if
        any rule refuses it: not finite, outside the range or the current limit -- as asked or as carried by
        the wire -- or beyond the instrument's full scale."""
        return self.rules.check(volts)

    def set_voltage(self, volts: float) -> None:
        """Check ``volts`` (V) against every rule (:meth:`check_setpoint`), then write it."""
        sent = self.check_setpoint(volts)
        self._writes += 1
        with delay_keyboard_interrupt():
            try:
                self._write_voltage(sent)
            except BaseException:
                self.unacknowledged = sent
                raise
        self.last_written = sent
        self.unacknowledged = None

    def read_voltage(self) -> float:
        """The set-point read back from the instrument (V)."""
        return float(self._read_voltage())

    def zero(self) -> None:
        """Put the heater in the safe state, 0 V (raises if the write fails; see :meth:`safe_state`)."""
        self.set_voltage(0.0)

    def safe_state(self) -> SafeState:
        """0 V, acknowledged and read back -- or plainly what is not known.  Never raises a driver fault.

        When the last answer was confirmed and nothing was written since,
        it stands (no traffic); otherwise 0 V is written and read back
        again, with the link's retries.
        """
        if self._safe is not None and self._safe[0] == self._writes and self._safe[1].confirmed:
            return self._safe[1]
        last = self.last_written
        pending = self.unacknowledged if self.unacknowledged is not None and not _is_zero(self.unacknowledged) else None
        try:
            self.set_voltage(0.0)
        except DriverError as exc:
            state = SafeState(False, False, None, last, f"the 0 V write was not acknowledged ({exc})", pending)
        else:
            try:
                back = 0.0 if self._write_reads_back() else self.read_voltage()
            except DriverError as exc:
                state = SafeState(False, True, None, last, f"0 V was acknowledged but could not be read back ({exc})")
            else:
                ok = _is_zero(back)
                why = "" if ok else f"0 V was acknowledged but the output reads back {back:g} V"
                state = SafeState(ok, True, back, last if not ok else 0.0, why)
        self._safe = (self._writes, state)
        return state

    def verify(self) -> bool:
        """Whether the link was re-established since the last call -- after checking that it is still
        the same instrument holding the same set-point, and sending that set-point again.

        Nothing goes on the wire when the link has not reconnected.  After a
        reconnection the instrument's identity (a boot id, where it has one)
        is compared with the one read at the first call, and its output read
        back and compared with the last acknowledged set-point; then the
        set-point is written again.  Raises :class:`ContinuityError` when the
        instrument restarted or lost its output -- its output and the beam's
        memory state cannot be trusted -- and a driver fault when it cannot
        be reached.  True tells the caller that what it measured spans a
        reconnection.
        """
        epoch = self._link_epoch()
        if self._epoch is None:  # the first call: the instrument as it is now is the reference
            self._identity = self._instrument_identity()
            self._epoch = self._link_epoch()
            return False
        if epoch == self._epoch:
            return False
        for _ in range(3):  # the checks themselves may reconnect again
            identity = self._instrument_identity()
            if identity != self._identity:
                raise ContinuityError(
                    f"the instrument restarted while the link was down (boot id {self._identity!r} -> "
                    f"{identity!r}): its output and the beam's memory state were lost"
                )
            if self.last_written is not None:
                back = self.read_voltage()
                if not same_setpoint(back, self.last_written):
                    raise ContinuityError(
                        f"after the link came back the output reads {back:g} V instead of the set-point "
                        f"{self.last_written:g} V: the instrument lost its output (restarted, or was reset), "
                        "so the beam's memory state cannot be trusted"
                    )
                self.set_voltage(self.last_written)
            if self._link_epoch() == epoch:
                break
            epoch = self._link_epoch()
        self._epoch = epoch
        return True

    def close(self) -> None:
        """Release the transport (does *not* change the output; :class:`Rig` zeroes first)."""

    def _on_wire(self, volts: float) -> float:
        """The value the instrument will actually receive for ``volts`` (default: exact)."""
        return volts

    def _write_reads_back(self) -> bool:
        """Whether :meth:`_write_voltage` itself reads the set-point back and raises on a mismatch."""
        return False

    def _link_epoch(self) -> int:
        """A number that changes whenever the link to the instrument is re-established (default: never)."""
        return 0

    def _instrument_identity(self) -> object | None:
        """Something that changes when the instrument restarts (a boot id), or None when it offers nothing."""
        return None

    @abc.abstractmethod
    def _write_voltage(self, volts: float) -> None:
        """Send an already-checked set-point (V) to the instrument."""

    @abc.abstractmethod
    def _read_voltage(self) -> float:
        """Read the instrument's current set-point (V)."""


class PSDSensor(abc.ABC):
    """A deflection sensor reading a PSD voltage and calibrating it to micrometres.

    Implements :class:`drivers.protocols.DeflectionSensor`.  A NaN reading or
    one at the rail (``|psd_V| >= saturation_V``) is retried ``retries``
    times -- reading is side-effect free -- then raises :class:`SensorError`.
    Subclasses provide :meth:`_read_psd`.
    """

    def __init__(self, calibration: Calibration, saturation_V: float = math.inf, retries: int = 2) -> None:
        self._calibration = calibration
        self.saturation_V = float(saturation_V)
        self.retries = int(retries)

    @property
    def calibration(self) -> Calibration:
        return self._calibration

    def read(self) -> Reading:
        problem = ""
        failed_before = self._failed_requests()
        for attempt in range(self.retries + 1):
            psd = float(self._read_psd())
            if not math.isfinite(psd):
                problem = f"the PSD reading was {psd}"
                continue
            if abs(psd) >= self.saturation_V:
                problem = (
                    f"the PSD is saturated ({psd:g} V, limit +-{self.saturation_V:g} V): "
                    "the laser spot is off the detector"
                )
                continue
            retried = attempt > 0 or self._failed_requests() != failed_before
            return Reading(self._calibration.to_um(psd), psd, self._calibration, retried)
        raise SensorError(f"no usable deflection reading after {self.retries + 1} attempts: {problem}")

    def close(self) -> None:
        """Release the transport."""

    def _failed_requests(self) -> int:
        """Requests on the link that failed and were retried so far (default: a link that never retries)."""
        return 0

    @abc.abstractmethod
    def _read_psd(self) -> float:
        """One raw PSD voltage (V) from the instrument (may be NaN)."""
