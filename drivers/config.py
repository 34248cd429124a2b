"""``rig.toml``: which driver, its connection, and the bench's limits and calibration.

:class:`RigConfig` assembles the tables: ``[heater]`` and ``[sensor]``
(:mod:`drivers.channel_config`) and one table per backend, each declared by
its backend's package with its entry (:data:`BACKENDS`).  Every key is
declared once, with its documentation, in those dataclasses (the
``rig.toml`` reference, ``docs/reference/rig-toml.md``, is generated from
them).  Loading rejects unknown keys (suggesting the closest one) and
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

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import modbus, serial, sim
from .backends import Backend
from .channel_config import HeaterConfig, SensorConfig
from .configschema import as_dict, parse_table, setting
from .errors import ConfigError

#: Every backend by its ``driver`` name: the one place a backend package is plugged in.
BACKENDS: dict[str, Backend] = {b.name: b for b in (sim.BACKEND, modbus.BACKEND, serial.BACKEND)}
DRIVERS = tuple(BACKENDS)
CLOCKS = ("real", "virtual")


@dataclass(frozen=True, kw_only=True)
class _Bench:
    """The keys of ``rig.toml`` that are not a backend's: which driver, the clock, the heater and the sensor."""

    driver: str = setting(f"which backend drives the rig: {', '.join(repr(d) for d in DRIVERS[:-1])} "
                          f"or {DRIVERS[-1]!r}", choices=DRIVERS)
    name: str = setting("a name for this bench, recorded with every session", default="")
    clock: str | None = setting(
        "'real' or 'virtual' (default: virtual for sim, real otherwise; virtual needs sim)",
        default=None, choices=CLOCKS,
    )
    heater: HeaterConfig = setting("[heater] heater output limits")
    sensor: SensorConfig = setting("[sensor] PSD calibration")

    def __post_init__(self) -> None:
        table = self.backend.table
        if getattr(self, table, None) is None:
            raise ValueError(f"driver = '{self.driver}' needs a [{table}] table")
        if self.clock == "virtual" and not self.backend.simulated:
            raise ValueError("clock = 'virtual' is only for driver = 'sim' (real hardware needs real time)")

    @property
    def backend(self) -> Backend:
        """The entry of the backend ``driver`` names."""
        return BACKENDS[self.driver]

    @property
    def clock_kind(self) -> str:
        return self.clock or ("virtual" if self.backend.simulated else "real")

    def to_dict(self) -> dict[str, Any]:
        """The configuration with every default filled in (JSON/TOML-friendly)."""
        return as_dict(self)


def _table(b: Backend) -> tuple[str, Any, Any]:
    """The field of :class:`RigConfig` holding backend ``b``'s table: always there (with its defaults) for a
    simulation, else present only when given."""
    if b.simulated:
        return b.table, b.config, setting(b.table_doc, default_factory=b.config)
    return b.table, b.config | None, setting(b.table_doc, default=None)


#: The whole ``rig.toml``: the bench's keys, then each backend's table -- the instruments' (``cfg.modbus``,
#: ``cfg.serial``), then the simulation's (``cfg.sim``) -- then where it came from (``source``, a path or
#: "<built-in>"; not a key).
RigConfig = dataclasses.make_dataclass(
    "RigConfig",
    [*(_table(b) for b in sorted(BACKENDS.values(), key=lambda b: b.simulated)),  # instruments', then sim's
     ("source", str, field(default="<built-in>", init=False, compare=False))],
    bases=(_Bench,), frozen=True, kw_only=True,
)
RigConfig.__module__ = __name__  # make_dataclass's own module= is Python 3.12's
RigConfig.__doc__ = "The whole ``rig.toml``: the bench's keys and every backend's table."


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
    params = sim.SimParams(**sim_changes)
    return RigConfig(
        driver="sim",
        heater=HeaterConfig(
            max_V=params.v_max_V,
            max_current_mA=12.78,
            series_resistance_ohm=params.series_resistance_ohm,
            heater_resistance_ohm=params.heater_resistance_ohm,
        ),
        sensor=SensorConfig(um_per_V=params.psd_um_per_V, offset_V=params.psd_offset_V),
        sim=params,
    )
