"""The :class:`Rig`: a heater, a deflection sensor and a clock, opened from ``rig.toml``.

::

    with open_rig(load_config("rig.toml")) as rig:
        rig.heater.set_voltage(2.5)
        rig.clock.sleep(10.0)
        reading = rig.sensor.read()        # reading.deflection_um, reading.psd_V

Opening connects (with the configured retries) and puts the heater at 0 V.
Leaving the ``with`` block -- normally, on any exception, on Ctrl-C --
returns the heater to 0 V (the write itself protected from a second
Ctrl-C) and closes the link.  What is known about the heater then is
:attr:`Rig.heater_state` (a :class:`~drivers.protocols.SafeState`): 0 V
*confirmed* (acknowledged and read back), or not.  If it is not,
:class:`SafeStateError` says so (attached as a note when another exception
is already on its way out, so the original cause is never hidden).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

from .channels import GuardedHeater, PSDSensor
from .clock import make_clock
from .config import RigConfig, default_config
from .errors import DeviceError, DriverError, SafeStateError
from .guard import delay_keyboard_interrupt
from .protocols import Clock, SafeState
from .sim.device import SimVO2


@dataclass
class Rig:
    """An open rig.  ``device`` is the simulated device when the driver is ``sim`` (for inspection)."""

    heater: GuardedHeater
    sensor: PSDSensor
    clock: Clock
    config: RigConfig
    description: dict[str, Any]
    device: SimVO2 | None = None
    _closers: list[Callable[[], None]] = field(default_factory=list, repr=False)
    closed: bool = False
    #: What is known about the heater after the last :meth:`safe_state` (None: not asked yet).
    heater_state: SafeState | None = None

    def zero(self) -> None:
        """Heater to 0 V now (protected from Ctrl-C while on the wire); raises if the write fails."""
        with delay_keyboard_interrupt():
            self.heater.zero()

    def safe_state(self) -> SafeState:
        """Heater to 0 V, and what is known afterwards (kept in :attr:`heater_state`); never raises a fault."""
        self.heater_state = self.heater.safe_state()
        return self.heater_state

    def close(self) -> None:
        """Heater to 0 V (confirmed, or :class:`SafeStateError`), then release the links.  Idempotent."""
        if self.closed:
            return
        self.closed = True
        try:
            state = self.safe_state()
        finally:
            for close in self._closers:
                try:
                    close()
                except Exception:  # closing a dead link must not hide anything
                    pass
        if not state.confirmed:
            raise SafeStateError(state.describe())

    def __enter__(self) -> "Rig":
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        try:
            self.close()
        except SafeStateError as err:
            if exc is None:
                raise
            exc.add_note(str(err))


def open_rig(
    config: RigConfig | None = None,
    *,
    clock: Clock | None = None,
    device: SimVO2 | None = None,
) -> Rig:
    """Open the rig described by ``config`` (default: the built-in simulated device).

    ``clock`` overrides the configured one; ``device`` supplies the
    simulated device for ``driver = "sim"`` (the rig then uses its clock).
    Raises :class:`ConnectionFailed` if the instrument cannot be reached;
    nothing is written before the connection is up.
    """
    cfg = config if config is not None else default_config()
    if clock is None and device is not None:
        clock = device.clock
    clk = clock if clock is not None else make_clock(cfg.clock_kind)
    limits = cfg.heater.limits()
    calibration = cfg.sensor.calibration()
    sens = cfg.sensor
    description: dict[str, Any] = {"driver": cfg.driver, "name": cfg.name, "clock": getattr(clk, "kind", "custom")}
    closers: list[Callable[[], None]] = []
    heater: GuardedHeater
    sensor: PSDSensor
    if cfg.driver == "sim":
        from .sim.backend import SimHeater, SimSensor

        if device is None:
            device = SimVO2(cfg.sim, clk)
        heater = SimHeater(device, limits)
        sensor = SimSensor(device, calibration, sens.saturation_V, sens.retries)
        description.update(endpoint="in-process", levels=cfg.sim.levels, time_constant_s=cfg.sim.time_constant_s)
    elif cfg.driver == "modbus":
        from .modbus_backend import ModbusHeater, ModbusLink, ModbusPSD

        assert cfg.modbus is not None
        link = ModbusLink(cfg.modbus)
        link.connect()
        closers.append(link.close)
        try:
            heater = ModbusHeater(link, limits)
        except DriverError:
            link.close()
            raise
        sensor = ModbusPSD(link, calibration, sens.saturation_V, sens.retries)
        description.update(
            endpoint=link.endpoint,
            setpoint=cfg.modbus.setpoint.describe(),
            psd=cfg.modbus.psd.describe(),
        )
    else:
        from .serial_backend import SerialHeater, SerialLink, SerialPSD

        assert cfg.serial is not None
        slink = SerialLink(cfg.serial)
        slink.connect()
        closers.append(slink.close)
        heater = SerialHeater(slink, limits)
        sensor = SerialPSD(slink, calibration, sens.saturation_V, sens.retries)
        try:
            identity = slink.query(cfg.serial.commands.identify)
        except DriverError:
            identity = ""
        description.update(endpoint=slink.endpoint, identity=identity)
    rig = Rig(heater, sensor, clk, cfg, description, device if cfg.driver == "sim" else None, closers)
    try:
        rig.zero()
        heater.verify()  # the instrument as it is now (its boot id) is the reference for reconnections
    except DriverError as exc:
        for close in closers:
            close()
        if isinstance(exc, DeviceError):
            raise
        raise type(exc)(f"the heater could not be set to 0 V on opening: {exc}") from exc
    return rig
