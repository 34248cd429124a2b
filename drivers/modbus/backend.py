"""The ``modbus`` driver: a pymodbus client (TCP, RTU over TCP, or RTU on a serial line).

One :class:`ModbusLink` per instrument, shared by the heater and the PSD.
Every request goes through :func:`drivers.retry.with_retries`: a refused,
reset or silent connection is closed, reopened after an exponential
back-off and the request repeated (all requests here are safe to repeat:
reads, and writes of an absolute set-point).  A Modbus exception response
becomes a named error from :mod:`drivers.modbus.errors`; "busy" and
"acknowledge" are retried, the others are not.

pymodbus's own retries are turned off (``retries=0``) so that exactly one
policy, the one in ``rig.toml``, applies; its log messages go to the
``pymodbus`` logger, which gets a NullHandler (:func:`quiet_pymodbus`) so a
dropped link is reported once, by us, rather than also on stderr.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.pdu import ExceptionResponse

from ..backends import OpenedBackend
from ..channels import GuardedHeater, PSDSensor
from ..errors import CodecError, ConfigError
from ..instrument_lock import host_port, serial_port_name
from ..limits import HeaterLimits
from ..protocols import Calibration, Clock
from ..retry import Backoff, BadReply, LinkDropped, NoReply, with_retries
from ..setpoint_rules import SetpointRules
from .config import ModbusConfig
from .errors import TRANSIENT_CODES, exception_response, quiet_pymodbus
from .registers import RegisterPoint
from .replies import STRICT_READS, read_request, reply_mismatch, write_request

quiet_pymodbus()


def make_client(cfg: ModbusConfig) -> ModbusTcpClient | ModbusSerialClient:
    """The pymodbus sync client for ``cfg`` (not connected yet), its register reads keeping their byte
    counts for the reply check (:mod:`drivers.modbus.replies`)."""
    client = _client(cfg)
    for cls in STRICT_READS:
        client.register(cls)
    return client


def _client(cfg: ModbusConfig) -> ModbusTcpClient | ModbusSerialClient:
    if cfg.transport == "rtu":
        return ModbusSerialClient(
            str(cfg.url),
            framer=FramerType.RTU,
            baudrate=cfg.baudrate,
            bytesize=cfg.bytesize,
            parity=cfg.parity,
            stopbits=cfg.stopbits,
            timeout=cfg.timeout_s,
            retries=0,
        )
    framer = FramerType.SOCKET if cfg.transport == "tcp" else FramerType.RTU
    return ModbusTcpClient(cfg.host, port=cfg.port, framer=framer, timeout=cfg.timeout_s, retries=0)


def _retryable(exc: BaseException) -> type[Exception]:
    """How a pymodbus failure is retried: the link dropped, no reply in time, or a bad reply."""
    if isinstance(exc, (ConnectionException, OSError)):
        return LinkDropped
    if isinstance(exc, ModbusIOException):
        return NoReply
    return BadReply


class ModbusLink:
    """A reconnecting Modbus client for one unit."""

    def __init__(self, cfg: ModbusConfig, sleep: Callable[[float], None] = time.sleep) -> None:
        self.cfg = cfg
        self.endpoint = cfg.endpoint()
        self._sleep = sleep
        self._client = make_client(cfg)
        self._backoff = Backoff(cfg.retries, cfg.backoff_s, cfg.backoff_max_s)
        #: Reconnections attempted since opening (for diagnostics and tests).
        self.reconnections = 0
        #: Connections established since opening: the first is 1, each later one a reconnection.
        self.connections = 0
        #: Requests that failed and were retried (or given up) since opening: no reply, a bad or mismatched
        #: reply, a dropped link.
        self.failed_attempts = 0

    # ------------------------------------------------------------ connection
    def _connect_once(self) -> None:
        if self._client.connected:
            return
        if not self._client.connect():
            raise LinkDropped("refused or unreachable")
        self.connections += 1

    def _reconnect(self) -> None:
        self._client.close()
        self.reconnections += 1
        self._connect_once()

    def connect(self) -> None:
        """Open the link (with the configured retries); :class:`ConnectionFailed` if it cannot."""
        with_retries(
            self._connect_once, reconnect=self._reconnect, backoff=self._backoff,
            what=f"connecting to {self.endpoint}", sleep=self._sleep,
        )

    def close(self) -> None:
        self._client.close()

    def _failed(self) -> None:
        self.failed_attempts += 1

    # ------------------------------------------------------------ requests
    def _request(self, what: str, request: Any, decode: Callable[[Any], Any] | None = None) -> Any:
        """Send the PDU ``request`` and check that the reply answers it (function code, unit, transaction,
        byte count: :func:`drivers.modbus.replies.reply_mismatch`); a mismatch is retried like garbage."""
        def attempt() -> Any:
            self._connect_once()
            try:
                response = self._client.execute(False, request)
            except (ModbusException, OSError) as exc:
                self._client.close()  # a late reply must never answer the next request
                raise _retryable(exc)(str(exc)) from None
            except BaseException:  # interrupted mid-transaction (Ctrl-C, SIGTERM): same rule
                self._client.close()
                raise
            mismatch = reply_mismatch(request, response)
            if mismatch is not None:
                self._client.close()  # whatever answers next may be the reply this one should have been
                raise BadReply(mismatch)
            if isinstance(response, ExceptionResponse) or response.isError():
                code = int(getattr(response, "exception_code", 0))
                error = exception_response(code, f"{what} on {self.endpoint}")
                if code in TRANSIENT_CODES:
                    raise BadReply(error)
                raise error
            if decode is None:
                return response
            try:
                return decode(response)
            except CodecError as exc:
                raise BadReply(str(exc)) from None

        return with_retries(
            attempt, reconnect=self._reconnect, backoff=self._backoff,
            what=f"{what} on {self.endpoint}", sleep=self._sleep, on_failure=self._failed,
        )

    def read(self, point: RegisterPoint, what: str) -> float:
        """Read and decode ``point``."""
        return self._request(
            f"reading {what} ({point.describe()})", read_request(point.table, point.address, point.count, self.cfg.unit_id),
            lambda response: point.decode(list(response.registers)),
        )

    def write(self, point: RegisterPoint, value: float, what: str) -> None:
        """Encode and write ``value`` to ``point`` (one request for all its registers)."""
        self._request(f"writing {what} ({point.describe()})", write_request(point.address, point.encode(value),
                                                                             self.cfg.unit_id))


class ModbusHeater(GuardedHeater):
    """The heater set-point in a holding register; the instrument's boot id in ``[modbus.boot_id]`` and
    its output's full scale in ``[modbus.full_scale]``, if it has them (read on opening)."""

    def __init__(self, link: ModbusLink, limits: HeaterLimits, full_scale_V: float | None = None) -> None:
        reported = None
        if link.cfg.full_scale is not None:
            reported = abs(link.read(link.cfg.full_scale, "the output's full scale"))
        known = [v for v in (full_scale_V, reported) if v is not None]
        super().__init__(limits, min(known) if known else None)
        self.link = link
        self.point = link.cfg.setpoint
        window = limits.window
        for edge in (window.min_V, window.max_V):
            try:
                self.point.raw(edge)
            except CodecError as exc:
                raise ConfigError(f"[modbus.setpoint] cannot hold the heater's limit {edge:g} V: {exc}") from None

    def _on_wire(self, volts: float) -> float:
        return self.point.on_wire(volts)

    def _write_voltage(self, volts: float) -> None:
        self.link.write(self.point, volts, "the heater set-point")

    def _read_voltage(self) -> float:
        return self.link.read(self.point, "the heater set-point")

    def _link_epoch(self) -> int:
        return self.link.connections

    def _instrument_identity(self) -> float | None:
        boot = self.link.cfg.boot_id
        return None if boot is None else self.link.read(boot, "the boot id")


class ModbusPSD(PSDSensor):
    """The PSD voltage in an input (or holding) register."""

    def __init__(self, link: ModbusLink, calibration: Calibration, saturation_V: float, retries: int) -> None:
        super().__init__(calibration, saturation_V, retries)
        self.link = link

    def _read_psd(self) -> float:
        return self.link.read(self.link.cfg.psd, "the PSD voltage")

    def _failed_requests(self) -> int:
        return self.link.failed_attempts


# ---------------------------------------------------------------- the backend (see drivers.backends)
def open_backend(cfg: Any, clock: Clock, device: object = None) -> OpenedBackend:
    """The ``modbus`` driver: connect (with the configured retries) and map the registers of ``[modbus]``."""
    m = cfg.modbus
    assert m is not None
    link = ModbusLink(m)
    link.connect()
    try:
        heater = ModbusHeater(link, cfg.heater.limits(), cfg.heater.full_scale_V)
    except BaseException:
        link.close()
        raise
    sens = cfg.sensor
    sensor = ModbusPSD(link, sens.calibration(), sens.saturation_V, sens.retries)
    description = {"endpoint": link.endpoint, "setpoint": m.setpoint.describe(), "psd": m.psd.describe()}
    return OpenedBackend(heater, sensor, [link.close], description)


def setpoint_rules(cfg: Any) -> SetpointRules:
    assert cfg.modbus is not None
    return SetpointRules(cfg.heater.limits(), cfg.modbus.setpoint.on_wire, cfg.heater.full_scale_V)


def instrument_address(cfg: Any) -> str | None:
    m = cfg.modbus
    assert m is not None
    if m.transport == "rtu":
        return f"modbus rtu {serial_port_name(str(m.url))} unit {m.unit_id}"
    return f"modbus {host_port(m.host, m.port)} unit {m.unit_id}"
