"""What a driver backend is: the entry each backend package declares, and what opening one returns.

A backend is a package -- :mod:`drivers.sim`, :mod:`drivers.modbus`,
:mod:`drivers.serial` -- that declares its ``rig.toml`` table (a dataclass
of :func:`~drivers.configschema.setting` keys) and its :class:`Backend`
entry, ``BACKEND``, in its ``__init__``; :mod:`drivers.config` assembles
the entries into :class:`~drivers.config.RigConfig` and the ``driver``
names.  The entry's implementation module provides three functions, each
given the whole configuration (a :class:`~drivers.config.RigConfig`), and
is imported only when a rig of that kind is used, so that ``pymodbus`` or
``pyserial`` load only when needed:

* ``open_backend(cfg, clock, device) -> OpenedBackend`` -- connect to the
  instrument described by the backend's own table and return its heater
  and sensor (which implement :class:`~drivers.protocols.HeaterOutput` and
  :class:`~drivers.protocols.DeflectionSensor`), the functions that close
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

A new backend is its package (its table, its entry, its implementation)
and its entry in :data:`drivers.config.BACKENDS`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .protocols import Clock, DeflectionSensor, HeaterOutput
    from .setpoint_rules import SetpointRules


@dataclass
class OpenedBackend:
    """What ``open_backend`` returns: the channels, how to close the links, and a description."""

    heater: HeaterOutput
    sensor: DeflectionSensor
    closers: list[Callable[[], None]] = field(default_factory=list)
    description: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Backend:
    """A backend's entry: the ``driver`` name, its ``rig.toml`` table and the dataclass declaring its keys
    (``table_doc`` describes the table in the reference), the module that implements it, what it is.

    ``simulated``: a simulation in this process -- its table is always there
    with its defaults (``rig serve-sim`` serves it whatever the driver), and
    it runs on a virtual clock unless ``clock = "real"``.
    """

    name: str
    table: str
    config: type
    module: str
    doc: str
    table_doc: str
    simulated: bool = False

    def load(self) -> ModuleType:
        return importlib.import_module(self.module)

    def open(self, cfg: Any, clock: Clock, device: Any = None) -> OpenedBackend:
        return self.load().open_backend(cfg, clock, device)

    def setpoint_rules(self, cfg: Any) -> SetpointRules:
        return self.load().setpoint_rules(cfg)

    def instrument_address(self, cfg: Any) -> str | None:
        return self.load().instrument_address(cfg)


def setpoint_rules(cfg: Any) -> SetpointRules:
    """The set-point rules of the rig ``cfg`` (a :class:`~drivers.config.RigConfig`) describes, as far as its
    configuration tells (an instrument that reports its own full scale adds that once it is opened: see the
    heater's ``check_setpoint``)."""
    return cfg.backend.setpoint_rules(cfg)
