"""The driver backends, by the names ``rig.toml`` uses for ``driver``: one registry, one entry each.

A backend is one module that provides three functions (imported only when
a rig of that kind is opened, so that ``pymodbus`` or ``pyserial`` load
only when needed):

* ``open_backend(cfg, clock, device) -> OpenedBackend`` -- connect to the
  instrument described by the backend's own ``rig.toml`` table and return
  its heater and sensor (which implement :class:`~drivers.protocols.HeaterOutput`
  and :class:`~drivers.protocols.DeflectionSensor`), the functions that close
  its links, and a description recorded with every session;
* ``setpoint_rules(cfg) -> SetpointRules`` -- every rule a set-point must
  pass as far as the configuration tells (the limits, what the wire makes
  of a value -- register rounding, a printed decimal -- and the full scale
  where it is configured), so a plan can be checked before anything is
  opened;
* ``instrument_address(cfg) -> str | None`` -- where the instrument is
  (``modbus tcp 192.0.2.10:502 unit 1``, a serial device), the key of the
  one-run-per-instrument lock; None for an instrument no other process can
  reach (the in-process simulator).

A new backend is its module, its table in :mod:`drivers.config`, and one
:func:`register_backend` line below.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .config import RigConfig
    from .protocols import Clock, DeflectionSensor, HeaterOutput
    from .setpoints import SetpointRules


@dataclass
class OpenedBackend:
    """What ``open_backend`` returns: the channels, how to close the links, and a description."""

    heater: HeaterOutput
    sensor: DeflectionSensor
    closers: list[Callable[[], None]] = field(default_factory=list)
    description: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Backend:
    """A registry entry: the ``driver`` name, its ``rig.toml`` table, the module that implements it."""

    name: str
    table: str
    module: str
    doc: str

    def load(self) -> ModuleType:
        return importlib.import_module(self.module)

    def open(self, cfg: RigConfig, clock: Clock, device: Any = None) -> OpenedBackend:
        return self.load().open_backend(cfg, clock, device)

    def setpoint_rules(self, cfg: RigConfig) -> SetpointRules:
        return self.load().setpoint_rules(cfg)

    def instrument_address(self, cfg: RigConfig) -> str | None:
        return self.load().instrument_address(cfg)


#: The backends by ``driver`` name.
BACKENDS: dict[str, Backend] = {}


def register_backend(backend: Backend) -> Backend:
    """Make ``backend`` available as ``driver = "<name>"``."""
    BACKENDS[backend.name] = backend
    return backend


def backend(name: str) -> Backend:
    """The backend called ``name`` (the configuration has already checked that it exists)."""
    return BACKENDS[name]


def setpoint_rules(cfg: RigConfig) -> SetpointRules:
    """The set-point rules of the rig ``cfg`` describes, as far as its configuration tells (an instrument
    that reports its own full scale adds that once it is opened: see the heater's ``check_setpoint``)."""
    return backend(cfg.driver).setpoint_rules(cfg)


register_backend(Backend("sim", "sim", "drivers.sim.backend", "the simulated VO2 device, in process"))
register_backend(Backend("modbus", "modbus", "drivers.modbus_backend",
                         "a Modbus instrument: TCP, RTU over TCP, or RTU on a serial line (pymodbus)"))
register_backend(Backend("serial", "serial", "drivers.serial_backend",
                         "an instrument with a line protocol on a serial port (pyserial), SCPI-like by default"))
