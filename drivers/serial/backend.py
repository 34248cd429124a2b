"""The ``serial`` driver: ASCII command lines over pyserial (SCPI-like by default).

Opened from any pyserial URL: ``/dev/ttyUSB0``, ``socket://host:port``,
``loop://``, ``rfc2217://...``.  The protocol (``[serial.commands]``):

* ``SOUR:VOLT 1.250000`` sets the heater (no reply);
* ``SOUR:VOLT?`` answers the set-point in volts;
* ``MEAS:DEFL?`` answers the PSD voltage in volts (the calibration to
  micrometres is ``[sensor]``'s);
* ``SYST:ERR?`` answers the last error, and a reply starting with ``ERR``
  is an error report.

Queries are retried after a timeout or a garbage reply (the input buffer is
flushed first); after a dropped link the port is reopened with back-off
and the request repeated (setting an absolute voltage twice is harmless).
With ``verify_set`` every set-point is read back and compared.
"""

from __future__ import annotations

import math
import socket
import time
from collections.abc import Callable
from typing import Any

import serial

from ..backends import OpenedBackend
from ..channels import GuardedHeater, PSDSensor
from ..errors import DeviceError, DriverError, SetpointRefused
from ..instrument_lock import serial_port_name
from ..limits import HeaterLimits
from ..protocols import Calibration, Clock
from ..retry import Backoff, BadReply, LinkDropped, NoReply, with_retries
from ..setpoint_rules import SetpointRules
from .config import SerialCommands, SerialConfig


class SerialLink:
    """A reconnecting line-protocol connection."""

    def __init__(self, cfg: SerialConfig, sleep: Callable[[float], None] = time.sleep) -> None:
        self.cfg = cfg
        self.endpoint = f"serial {cfg.url}"
        self._sleep = sleep
        self._port: serial.SerialBase | None = None
        self._backoff = Backoff(cfg.retries, cfg.backoff_s, cfg.backoff_max_s)
        self._eol = cfg.read_termination.encode(cfg.encoding)
        self.reconnections = 0
        #: Times the port was opened: the first is 1, each later one a reconnection.
        self.connections = 0
        #: Requests that failed and were retried (or given up) since opening.
        self.failed_attempts = 0

    def _failed(self) -> None:
        self.failed_attempts += 1

    # ------------------------------------------------------------ connection
    def _open_once(self) -> None:
        if self._port is not None:
            return
        try:
            self._port = serial.serial_for_url(
                self.cfg.url, baudrate=self.cfg.baudrate, timeout=self.cfg.timeout_s,
                write_timeout=self.cfg.timeout_s,
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkDropped(str(exc) if self.cfg.url in str(exc) else f"cannot open {self.cfg.url}: {exc}") from None
        self.connections += 1
        sock = getattr(self._port, "_socket", None)  # socket:// -- a command then a query must not wait for Nagle
        if isinstance(sock, socket.socket):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def _reconnect(self) -> None:
        self.close()
        self.reconnections += 1
        self._open_once()

    def connect(self) -> None:
        """Open the port (with the configured retries); :class:`ConnectionFailed` if it cannot."""
        with_retries(self._open_once, reconnect=self._reconnect, backoff=self._backoff,
                     what=f"opening {self.endpoint}", sleep=self._sleep)

    def close(self) -> None:
        if self._port is not None:
            try:
                self._port.close()
            finally:
                self._port = None

    # ------------------------------------------------------------ lines
    def _send(self, line: str) -> None:
        self._open_once()
        assert self._port is not None
        try:
            self._port.write((line + self.cfg.write_termination).encode(self.cfg.encoding))
            self._port.flush()
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise LinkDropped(f"writing '{line}': {exc}") from None

    def _receive(self, line: str) -> str:
        assert self._port is not None
        try:
            raw = self._port.read_until(self._eol)
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise LinkDropped(f"reading the reply to '{line}': {exc}") from None
        except BaseException:  # interrupted while the reply was on its way: it must not answer the next query
            self.close()
            raise
        if not raw.endswith(self._eol):
            self.close()  # a late reply must not answer the next query
            raise NoReply(f"'{line}' got {'no reply' if not raw else repr(raw)} within {self.cfg.timeout_s:g} s")
        try:
            return raw[: -len(self._eol)].decode(self.cfg.encoding).strip()
        except UnicodeDecodeError:
            raise BadReply(f"'{line}' got undecodable bytes {raw!r}") from None

    def command(self, line: str) -> None:
        """Send a command that has no reply."""
        with_retries(lambda: self._send(line), reconnect=self._reconnect, backoff=self._backoff,
                     what=f"sending '{line}' to {self.endpoint}", sleep=self._sleep)

    def query(self, line: str) -> str:
        """Send a query and return its reply line (error replies raise :class:`DeviceError`)."""
        def attempt() -> str:
            self._open_once()
            assert self._port is not None
            try:
                self._port.reset_input_buffer()
            except (serial.SerialException, OSError) as exc:
                self.close()
                raise LinkDropped(str(exc)) from None
            self._send(line)
            return self._receive(line)

        reply = with_retries(attempt, reconnect=self._reconnect, backoff=self._backoff,
                             what=f"querying '{line}' on {self.endpoint}", sleep=self._sleep, on_failure=self._failed)
        prefix = self.cfg.commands.error_prefix
        if prefix and reply.startswith(prefix):
            raise DeviceError(f"{self.endpoint} answered '{line}' with an error: {reply}")
        return reply

    def query_number(self, line: str) -> float:
        """A query whose reply is one number (NaN allowed); garbage is retried."""
        def attempt() -> float:
            reply = self.query(line)
            try:
                return float(reply)
            except ValueError:
                raise BadReply(f"'{line}' got {reply!r}, not a number") from None

        return with_retries(attempt, reconnect=lambda: None, backoff=self._backoff,
                            what=f"querying '{line}' on {self.endpoint}", sleep=self._sleep, on_failure=self._failed)

    def last_error(self) -> str:
        """The instrument's answer to the error query ('' when there is none or no error query)."""
        if not self.cfg.commands.error_query:
            return ""
        try:
            return self.query(self.cfg.commands.error_query)
        except DeviceError as exc:
            return str(exc)


def _printed(commands: SerialCommands, volts: float) -> float:
    """The value the instrument reads from the set command for ``volts`` (V), after printing."""
    sent = commands.value_on_wire(volts)
    assert sent is not None  # checked when the configuration was loaded
    return sent


class SerialHeater(GuardedHeater):
    """The heater set by a command line, read back by a query."""

    def __init__(self, link: SerialLink, limits: HeaterLimits, full_scale_V: float | None = None) -> None:
        super().__init__(limits, full_scale_V)
        self.link = link
        self.commands = link.cfg.commands

    def _on_wire(self, volts: float) -> float:
        return _printed(self.commands, volts)

    def _write_voltage(self, volts: float) -> None:
        self.link.command(self.commands.format_set(volts))
        if not self.link.cfg.verify_set:
            return
        back = self.link.query_number(self.commands.query_voltage)
        if not (math.isfinite(back) and math.isclose(back, volts, rel_tol=1e-6, abs_tol=1e-6)):
            reason = self.link.last_error()
            refused = bool(reason) and not reason.startswith("0,")  # the instrument queued an error: a refusal
            raise (SetpointRefused if refused else DeviceError)(
                f"{self.link.endpoint}: heater set to {volts:g} V but it reports {back:g} V"
                + (f"; instrument error: {reason}" if reason else "")
            )

    def _read_voltage(self) -> float:
        return self.link.query_number(self.commands.query_voltage)

    def _write_reads_back(self) -> bool:
        return self.link.cfg.verify_set

    def _link_epoch(self) -> int:
        return self.link.connections


class SerialPSD(PSDSensor):
    """The PSD voltage answered by a query."""

    def __init__(self, link: SerialLink, calibration: Calibration, saturation_V: float, retries: int) -> None:
        super().__init__(calibration, saturation_V, retries)
        self.link = link

    def _read_psd(self) -> float:
        return self.link.query_number(self.link.cfg.commands.measure_psd)

    def _failed_requests(self) -> int:
        return self.link.failed_attempts


# ---------------------------------------------------------------- the backend (see drivers.backends)
def open_backend(cfg: Any, clock: Clock, device: object = None) -> OpenedBackend:
    """The ``serial`` driver: open the port of ``[serial]`` (with the configured retries) and ask who it is."""
    sc = cfg.serial
    assert sc is not None
    link = SerialLink(sc)
    link.connect()
    sens = cfg.sensor
    heater = SerialHeater(link, cfg.heater.limits(), cfg.heater.full_scale_V)
    sensor = SerialPSD(link, sens.calibration(), sens.saturation_V, sens.retries)
    try:
        identity = link.query(sc.commands.identify)
    except DriverError:
        identity = ""
    return OpenedBackend(heater, sensor, [link.close], {"endpoint": link.endpoint, "identity": identity})


def setpoint_rules(cfg: Any) -> SetpointRules:
    assert cfg.serial is not None
    commands = cfg.serial.commands
    return SetpointRules(cfg.heater.limits(), lambda volts: _printed(commands, volts), cfg.heater.full_scale_V)


def instrument_address(cfg: Any) -> str | None:
    assert cfg.serial is not None
    return f"serial {serial_port_name(cfg.serial.url)}"
