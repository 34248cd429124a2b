"""The simulated device as an in-process driver: a heater and a PSD wired straight to :class:`SimVO2`.

This is the ``sim`` driver of ``rig.toml``: no transport at all, so with a
virtual clock a whole identification run costs only the physics.  The same
device served over Modbus or a serial line is :mod:`drivers.sim.bench`.
"""

from __future__ import annotations

from typing import Any

from ..backends import OpenedBackend
from ..channels import GuardedHeater, PSDSensor
from ..limits import HeaterLimits
from ..protocols import Calibration, Clock
from ..setpoint_rules import SetpointRules
from .device import SimVO2


class SimHeater(GuardedHeater):
    """Heater output of a :class:`SimVO2` (limits enforced by :class:`GuardedHeater`; the device's
    ``max_output_V`` is the full scale, unless the configuration says less)."""

    def __init__(self, device: SimVO2, limits: HeaterLimits, full_scale_V: float | None = None) -> None:
        fs = device.params.max_output_V if full_scale_V is None else min(full_scale_V, device.params.max_output_V)
        super().__init__(limits, fs)
        self.device = device

    def _write_voltage(self, volts: float) -> None:
        self.device.apply_voltage(volts)

    def _read_voltage(self) -> float:
        return self.device.applied_voltage


class SimSensor(PSDSensor):
    """PSD of a :class:`SimVO2`."""

    def __init__(self, device: SimVO2, calibration: Calibration, saturation_V: float, retries: int = 2) -> None:
        super().__init__(calibration, saturation_V, retries)
        self.device = device

    def _read_psd(self) -> float:
        return self.device.read_psd()


# ---------------------------------------------------------------- the backend (see drivers.backends)
def open_backend(cfg: Any, clock: Clock, device: SimVO2 | None = None) -> OpenedBackend:
    """The ``sim`` driver: the device of ``[sim]`` (or ``device``) on ``clock``; no link to open."""
    if device is None:
        device = SimVO2(cfg.sim, clock)
    sens = cfg.sensor
    heater = SimHeater(device, cfg.heater.limits(), cfg.heater.full_scale_V)
    sensor = SimSensor(device, sens.calibration(), sens.saturation_V, sens.retries)
    return OpenedBackend(heater, sensor, [], {"endpoint": "in-process", "levels": cfg.sim.levels,
                                              "time_constant_s": cfg.sim.time_constant_s})


def setpoint_rules(cfg: Any) -> SetpointRules:
    fs = cfg.sim.max_output_V if cfg.heater.full_scale_V is None else min(cfg.heater.full_scale_V, cfg.sim.max_output_V)
    return SetpointRules(cfg.heater.limits(), None, fs)


def instrument_address(cfg: Any) -> str | None:
    return None  # each process has its own simulated device
