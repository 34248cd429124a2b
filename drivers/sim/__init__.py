"""The simulated VO2 microactuator: a first-class backend, in process or served over real protocols.

Its entry, ``BACKEND``, is the ``sim`` driver of ``rig.toml``.

* :mod:`~drivers.sim.params` -- physical parameters (the ``[sim]`` table);
* :mod:`~drivers.sim.transition` -- the phase-transition Preisach density;
* :mod:`~drivers.sim.device` -- :class:`SimVO2`, the physics and its state;
* :mod:`~drivers.sim.effect_hooks` -- the hook for extra physical effects;
* :mod:`~drivers.sim.builtin_effects` -- the unmodelled effects (thermal lag,
  drifts, Joule power, creep, sensor nonlinearity) and their registry;
* :mod:`~drivers.sim.faults` -- faults to inject in tests;
* :mod:`~drivers.sim.backend` -- the in-process ``sim`` driver;
* :mod:`~drivers.sim.modbus_server`, :mod:`~drivers.sim.serial_server`,
  :mod:`~drivers.sim.bench` -- the device behind a pymodbus server and a
  line-protocol server (``rig serve-sim``).
"""

from ..backends import Backend
from .device import DeviceRefused, SimState, SimVO2
from .builtin_effects import EFFECTS, SIM_EFFECT_CLASSES
from .effect_hooks import Effect, Moment
from .faults import FaultPlan
from .params import SimParams

BACKEND = Backend("sim", "sim", SimParams, "drivers.sim.backend", "the simulated VO2 device, in process",
                  "[sim] the simulated device (driver = 'sim' and rig serve-sim)", simulated=True)

__all__ = [
    "BACKEND",
    "EFFECTS",
    "SIM_EFFECT_CLASSES",
    "DeviceRefused",
    "Effect",
    "FaultPlan",
    "Moment",
    "SimParams",
    "SimState",
    "SimVO2",
]
