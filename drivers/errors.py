"""Errors raised by the drivers: one class per thing that can go wrong.

Every one is a :class:`DriverError`, which the command line turns into a
one-line ``Error: ...`` (exit code 2).  Callers that can recover (retry a
read, reconnect) catch the narrow classes; everything else lets them rise,
and the :class:`~drivers.rig.Rig` puts the heater at 0 V on the way out.
"""

from __future__ import annotations


class DriverError(Exception):
    """Something about the rig, its configuration or its connection went wrong."""


class ConfigError(DriverError, ValueError):
    """``rig.toml`` is malformed: unknown or missing key, wrong type, bad value."""


class LimitError(DriverError, ValueError):
    """A heater set-point was refused before anything was written.

    ``check`` names the limit that refused it (``finite``, ``voltage``,
    ``current``, ``resolution``); ``volts`` is the requested value.
    """

    def __init__(self, message: str, *, check: str, volts: float) -> None:
        super().__init__(message)
        self.check = check
        self.volts = volts


class ConnectionFailed(DriverError):
    """The instrument could not be reached, or the link dropped and did not come back."""


class DriverTimeout(ConnectionFailed):
    """The instrument did not answer in time (after the configured retries)."""


class ProtocolError(DriverError):
    """The instrument answered something that is not a valid reply (garbage, wrong length)."""


class DeviceError(DriverError):
    """The instrument answered with an error of its own (SCPI error reply, device fault)."""


class SetpointRefused(DeviceError):
    """The instrument refused a set-point (beyond its range): a plan with that point cannot run on it."""


class SetpointNotApplied(DeviceError):
    """The instrument acknowledged a set-point but its output reads back another value: it did not apply it
    (a write dropped on the way, an output in local mode or interlocked)."""


class SensorError(DriverError):
    """The PSD gave no usable reading (NaN, or saturated at a rail) after the retries."""


class ContinuityError(ConnectionFailed):
    """After a reconnection the instrument is not the one the run was talking to: it restarted (its boot
    id changed) or lost its output.  Whatever state the beam was in -- its hysteresis memory -- is gone."""


class SafeStateError(DriverError):
    """The heater could not be confirmed at 0 V when it had to be."""


class CodecError(DriverError, ValueError):
    """A value cannot be represented in a register format (NaN in an integer, overflow)."""


class InstrumentBusy(DriverError):
    """Another run holds the instrument (one run per instrument; see :mod:`drivers.instrument_lock`)."""


class ServeError(DriverError, ValueError):
    """The simulated bench cannot listen where it was asked to (address in use, bad address)."""
