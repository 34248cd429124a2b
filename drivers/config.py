"""``rig.toml``: which driver, its connection, and the bench's limits and calibration.

Every key is declared once, with its documentation, in the dataclasses
below (the ``rig.toml`` reference, ``docs/reference/rig-toml.md``, is generated
from them).  Loading rejects unknown keys (suggesting the closest one) and
missing required ones, naming the key.  Example::

    driver = "modbus"            # sim | modbus | serial

    [heater]
    max_V = 6.0
    max_current_mA = 12.78
    series_resistance_ohm = 682.5

    [sensor]
    um_per_V = 5.0

    [modbus]
    transport = "tcp"
    host = "192.0.2.10"
    port = 502

    [modbus.setpoint]            # holding register 0..1
    address = 0
    type = "float32"

    [modbus.psd]                 # input register 0, millivolts
    address = 0
    type = "int16"
    scale = 1000.0
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .backends import BACKENDS
from .configschema import as_dict, parse_table, setting
from .errors import ConfigError
from .limits import HeaterLimits
from .modbus_registers import InputPoint, RegisterPoint, overlap
from .protocols import Calibration
from .sim.params import SimParams

DRIVERS = tuple(BACKENDS)
CLOCKS = ("real", "virtual")
MODBUS_TRANSPORTS = ("tcp", "rtu-over-tcp", "rtu")


@dataclass(frozen=True, kw_only=True)
class HeaterConfig:
    """``[heater]``: the heater output's limits (checked before anything is written)."""

    max_V: float = setting("largest heater set-point", unit="V")
    min_V: float = setting("smallest heater set-point (must allow 0 V)", default=0.0, unit="V")
    max_current_mA: float | None = setting(
        "largest current through the series resistor (paper: 12.78 mA); omit for no current limit",
        default=None, unit="mA", positive=True,
    )
    series_resistance_ohm: float | None = setting(
        "external current-limiting resistor; required with max_current_mA", default=None, unit="ohm", positive=True
    )
    heater_resistance_ohm: float = setting(
        "on-chip heater resistance, added to the series one for the current (0: unknown, conservative)",
        default=0.0, unit="ohm", minimum=0.0,
    )
    selftest_V: float = setting("the small, safe voltage 'rig selftest' applies", default=0.5, unit="V")
    full_scale_V: float | None = setting(
        "the output's full scale from the instrument's datasheet (+-V); set-points beyond it are refused before "
        "a run, and 'rig selftest' fails if the window reaches beyond it (omit: unknown, or read from the "
        "instrument where it reports it)",
        default=None, unit="V", positive=True,
    )

    def __post_init__(self) -> None:
        if not self.min_V <= 0.0 <= self.max_V or not self.max_V > self.min_V:
            raise ValueError(f"need min_V <= 0 <= max_V and max_V > min_V, got [{self.min_V}, {self.max_V}]")
        if self.max_current_mA is not None and self.series_resistance_ohm is None:
            raise ValueError("max_current_mA needs series_resistance_ohm to compute the current")
        if self.selftest_V not in self.limits().window:
            raise ValueError(f"selftest_V = {self.selftest_V} V is outside the heater's limits")

    def limits(self) -> HeaterLimits:
        return HeaterLimits.build(
            self.min_V, self.max_V, self.max_current_mA, self.series_resistance_ohm, self.heater_resistance_ohm
        )


@dataclass(frozen=True, kw_only=True)
class SensorConfig:
    """``[sensor]``: the PSD calibration and what counts as a usable reading."""

    um_per_V: float = setting("calibration: micrometres of deflection per PSD volt (non-zero)", unit="um/V")
    offset_V: float = setting("PSD voltage at zero deflection", default=0.0, unit="V")
    saturation_V: float = setting(
        "a reading with |PSD| at or above this is saturated (the spot is off the detector)",
        default=9.9, unit="V", positive=True,
    )
    retries: int = setting("extra attempts after a NaN or saturated reading", default=2, minimum=0, maximum=100)

    def __post_init__(self) -> None:
        if self.um_per_V == 0:
            raise ValueError("um_per_V must not be 0")

    def calibration(self) -> Calibration:
        return Calibration(self.um_per_V, self.offset_V)


@dataclass(frozen=True, kw_only=True)
class LinkConfig:
    """Timeouts and reconnection shared by the Modbus and serial links."""

    timeout_s: float = setting("time to wait for a reply", default=1.0, unit="s", positive=True)
    retries: int = setting(
        "extra attempts after a timeout or a dropped link (reconnecting in between)", default=3, minimum=0, maximum=100
    )
    backoff_s: float = setting("wait before the first reconnection; doubles each time", default=0.1, unit="s", minimum=0.0)
    backoff_max_s: float = setting("longest wait between reconnections", default=2.0, unit="s", minimum=0.0)


@dataclass(frozen=True, kw_only=True)
class ModbusConfig(LinkConfig):
    """``[modbus]``: a pymodbus client and the register map."""

    transport: str = setting(
        "'tcp' (Modbus TCP), 'rtu-over-tcp' (RTU frames over a TCP socket) or 'rtu' (RTU on a serial line)",
        default="tcp", choices=MODBUS_TRANSPORTS,
    )
    host: str = setting("server address for tcp and rtu-over-tcp", default="127.0.0.1")
    port: int = setting("server TCP port for tcp and rtu-over-tcp", default=502, minimum=1, maximum=65535)
    url: str | None = setting("serial port or pyserial URL for rtu (/dev/ttyUSB0, socket://host:port)", default=None)
    baudrate: int = setting("serial speed for rtu", default=19200, positive=True)
    parity: str = setting("serial parity for rtu: 'N', 'E' or 'O'", default="N", choices=("N", "E", "O"))
    stopbits: int = setting("serial stop bits for rtu", default=1, choices=(1, 2))
    bytesize: int = setting("serial data bits for rtu", default=8, choices=(7, 8))
    unit_id: int = setting("Modbus unit (slave) id of the instrument", default=1, minimum=0, maximum=247)
    setpoint: RegisterPoint = setting("[modbus.setpoint] the heater set-point register (V), a holding register")
    psd: InputPoint = setting("[modbus.psd] the PSD voltage register (V)")
    boot_id: InputPoint | None = setting(
        "[modbus.boot_id] optional: a register whose value changes whenever the instrument restarts "
        "(a boot counter or random boot id), read on opening and after every reconnection",
        default=None,
    )
    full_scale: InputPoint | None = setting(
        "[modbus.full_scale] optional: a register holding the heater output's full scale (V), read on opening",
        default=None,
    )

    def points(self) -> dict[str, RegisterPoint]:
        """Every configured register by its table name (``setpoint``, ``psd``, and the optional ones)."""
        named = {"setpoint": self.setpoint, "psd": self.psd, "boot_id": self.boot_id, "full_scale": self.full_scale}
        return {name: p for name, p in named.items() if p is not None}

    def __post_init__(self) -> None:
        if self.transport == "rtu" and not self.url:
            raise ValueError("transport = 'rtu' needs url (the serial port)")
        if self.setpoint.table != "holding":
            raise ValueError("the heater set-point must be a holding register (it is written)")
        named = list(self.points().items())
        for i, (a, pa) in enumerate(named):
            for b, pb in named[i + 1:]:
                if overlap(pa, pb):
                    raise ValueError(f"the {a} and {b} registers overlap")

    @classmethod
    def simulated(cls, **changes: Any) -> "ModbusConfig":
        """The simulated bench's default: float32 set-point in holding 0, float32 PSD in input 0,
        the boot id as a uint32 in input 2, the output's full scale as a float32 in input 4."""
        changes.setdefault("setpoint", RegisterPoint(address=0))
        changes.setdefault("psd", InputPoint(address=0))
        changes.setdefault("boot_id", InputPoint(address=2, type="uint32"))
        changes.setdefault("full_scale", InputPoint(address=4))
        return cls(**changes)

    def endpoint(self) -> str:
        """Where the instrument is, for messages."""
        if self.transport == "rtu":
            return f"modbus rtu {self.url} unit {self.unit_id}"
        return f"modbus {self.transport} {self.host}:{self.port} unit {self.unit_id}"


@dataclass(frozen=True, kw_only=True)
class SerialCommands:
    """``[serial.commands]``: the line protocol (SCPI-like by default)."""

    set_voltage: str = setting(
        "command that sets the heater; '{volts}' is replaced by the set-point (Python format spec allowed)",
        default="SOUR:VOLT {volts:.6f}",
    )
    query_voltage: str = setting("query answered by the set-point in volts", default="SOUR:VOLT?")
    measure_psd: str = setting("query answered by the PSD voltage in volts", default="MEAS:DEFL?")
    identify: str = setting("identification query", default="*IDN?")
    error_query: str = setting("query answered by the instrument's last error ('' if none)", default="SYST:ERR?")
    error_prefix: str = setting("a reply starting with this is an error report", default="ERR")

    def __post_init__(self) -> None:
        try:
            text = self.set_voltage.format(volts=1.25)
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"set_voltage must contain '{{volts}}' and nothing else to fill: {exc}") from None
        if text == self.set_voltage:
            raise ValueError("set_voltage must contain '{volts}'")
        if self.value_on_wire(1.25) is None:
            raise ValueError(f"set_voltage {self.set_voltage!r} does not print the value as a number")
        for name in ("query_voltage", "measure_psd", "identify"):
            if not getattr(self, name).strip():
                raise ValueError(f"{name} must not be empty")

    def format_set(self, volts: float) -> str:
        return self.set_voltage.format(volts=volts)

    @property
    def set_prefix(self) -> str:
        """The constant text before the value in :attr:`set_voltage`."""
        return self.set_voltage.split("{", 1)[0]

    def value_on_wire(self, volts: float) -> float | None:
        """The number the instrument reads from the set command for ``volts`` (after printing)."""
        return parse_leading_number(self.format_set(volts)[len(self.set_prefix):])


_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


def parse_leading_number(text: str) -> float | None:
    """The decimal number at the start of ``text`` (after blanks), or None."""
    m = _NUMBER.match(text)
    return float(m.group(1)) if m else None


@dataclass(frozen=True, kw_only=True)
class SerialConfig(LinkConfig):
    """``[serial]``: a pyserial line and its ASCII commands."""

    url: str = setting("serial port or pyserial URL: /dev/ttyUSB0, socket://host:port, loop://")
    baudrate: int = setting("serial speed (ignored by socket://)", default=115200, positive=True)
    write_termination: str = setting("appended to every command", default="\n")
    read_termination: str = setting("ends every reply", default="\n")
    encoding: str = setting("text encoding of the line", default="ascii")
    verify_set: bool = setting("read the set-point back after each write and compare", default=True)
    commands: SerialCommands = setting("[serial.commands] the command set", default_factory=SerialCommands)

    def __post_init__(self) -> None:
        if not self.write_termination or not self.read_termination:
            raise ValueError("terminations must not be empty")
        try:
            "x".encode(self.encoding)
        except LookupError:
            raise ValueError(f"unknown encoding {self.encoding!r}") from None


@dataclass(frozen=True, kw_only=True)
class RigConfig:
    """The whole ``rig.toml``."""

    driver: str = setting("which backend drives the rig: 'sim', 'modbus' or 'serial'", choices=DRIVERS)
    name: str = setting("a name for this bench, recorded with every session", default="")
    clock: str | None = setting(
        "'real' or 'virtual' (default: virtual for sim, real otherwise; virtual needs sim)",
        default=None, choices=CLOCKS,
    )
    heater: HeaterConfig = setting("[heater] heater output limits")
    sensor: SensorConfig = setting("[sensor] PSD calibration")
    modbus: ModbusConfig | None = setting("[modbus] required when driver = 'modbus'", default=None)
    serial: SerialConfig | None = setting("[serial] required when driver = 'serial'", default=None)
    sim: SimParams = setting("[sim] the simulated device (driver = 'sim' and rig serve-sim)", default_factory=SimParams)
    #: Where the configuration came from (a path, or "<built-in>"); not a key.
    source: str = field(default="<built-in>", init=False, compare=False)

    def __post_init__(self) -> None:
        table = BACKENDS[self.driver].table
        if getattr(self, table, None) is None:
            raise ValueError(f"driver = '{self.driver}' needs a [{table}] table")
        if self.clock == "virtual" and self.driver != "sim":
            raise ValueError("clock = 'virtual' is only for driver = 'sim' (real hardware needs real time)")

    @property
    def clock_kind(self) -> str:
        return self.clock or ("virtual" if self.driver == "sim" else "real")

    def to_dict(self) -> dict[str, Any]:
        """The configuration with every default filled in (JSON/TOML-friendly)."""
        return as_dict(self)


def parse_config(data: dict[str, Any], source: str = "<string>") -> RigConfig:
    """A :class:`RigConfig` from parsed TOML; :class:`ConfigError` names the offending key."""
    try:
        cfg = parse_table(RigConfig, data)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    object.__setattr__(cfg, "source", source)
    return cfg


def loads_config(text: str, source: str = "<string>") -> RigConfig:
    """Parse ``rig.toml`` text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML: {exc}") from None
    return parse_config(data, source)


def load_config(path: str | Path) -> RigConfig:
    """Read ``rig.toml`` from ``path`` (only read, never written)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read: {exc}") from None
    return loads_config(text, str(p))


def default_config(**sim_changes: Any) -> RigConfig:
    """The built-in configuration: the simulated device on a virtual clock, the paper's current limit."""
    sim = SimParams(**sim_changes)
    cfg = RigConfig(
        driver="sim",
        heater=HeaterConfig(
            max_V=sim.v_max_V,
            max_current_mA=12.78,
            series_resistance_ohm=sim.series_resistance_ohm,
            heater_resistance_ohm=sim.heater_resistance_ohm,
        ),
        sensor=SensorConfig(um_per_V=sim.psd_um_per_V, offset_V=sim.psd_offset_V),
        sim=sim,
    )
    return cfg
