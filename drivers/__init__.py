"""Drivers for the VO2 rig: heater output, PSD deflection sensor, clock -- real or simulated.

Layers (one module, one job):

* :mod:`~drivers.protocols` -- the small typed interfaces the sequencer uses
  (:class:`HeaterOutput`, :class:`DeflectionSensor`, :class:`Clock`);
* :mod:`~drivers.channels` -- base classes that enforce the limits and retry
  bad readings in the public methods, their transactions held against
  Ctrl-C (:mod:`interrupts`); :mod:`~drivers.limits` -- the limits;
* :mod:`~drivers.clock` -- real and virtual clocks;
* :mod:`~drivers.retry` -- reconnection with back-off (and the keys every
  link shares);
* :mod:`~drivers.backends` -- what a backend is: the entry its package
  declares; :mod:`~drivers.setpoint_rules` -- every rule a set-point passes, the
  window; :mod:`~drivers.instrument_lock` -- one run per instrument;
* the backends, one package each, each declaring its ``rig.toml`` table and
  its entry: :mod:`~drivers.sim` (the simulated VO2 device and its
  servers), :mod:`~drivers.modbus`, :mod:`~drivers.serial`;
* :mod:`~drivers.config` -- ``rig.toml``, assembled from ``[heater]``,
  ``[sensor]`` (:mod:`~drivers.channel_config`) and the backends' tables
  (schema in :mod:`~drivers.configschema`);
* :mod:`~drivers.rig` -- :class:`Rig` and :func:`open_rig`;
  :mod:`~drivers.selftest` -- ``rig selftest``.
"""

from .clock import RealClock, VirtualClock
from .config import RigConfig, default_config, load_config, loads_config
from .errors import (
    CodecError,
    ConfigError,
    ConnectionFailed,
    ContinuityError,
    DeviceError,
    DriverError,
    DriverTimeout,
    InstrumentBusy,
    LimitError,
    ProtocolError,
    SafeStateError,
    SensorError,
    SetpointRefused,
)
from .protocols import Calibration, Clock, DeflectionSensor, HeaterOutput, Reading, SafeState, VoltageWindow
from .rig import Rig, open_rig

__all__ = [
    "Calibration",
    "Clock",
    "CodecError",
    "ConfigError",
    "ConnectionFailed",
    "ContinuityError",
    "DeflectionSensor",
    "DeviceError",
    "DriverError",
    "DriverTimeout",
    "HeaterOutput",
    "InstrumentBusy",
    "LimitError",
    "ProtocolError",
    "Reading",
    "RealClock",
    "Rig",
    "RigConfig",
    "SafeState",
    "SafeStateError",
    "SensorError",
    "SetpointRefused",
    "VirtualClock",
    "VoltageWindow",
    "default_config",
    "load_config",
    "loads_config",
    "open_rig",
]
