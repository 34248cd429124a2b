"""The :class:`Rig`: a heater, a deflection sensor and a clock, opened from ``rig.toml``.

::

    with open_rig(load_config("rig.toml")) as rig:
        rig.heater.set_voltage(2.5)
        rig.clock.sleep(10.0)
        reading = rig.sensor.read()        # reading.deflection_um, reading.psd_V

Opening takes the instrument's lock (one run per instrument, see
:mod:`drivers.instrument_lock`), connects through the backend named by
``driver`` (:mod:`drivers.backends`), with the configured retries, and puts
the heater at 0 V.
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

from interrupts import delay_keyboard_interrupt

from .clock import make_clock
from .config import RigConfig, default_config
from .errors import DeviceError, DriverError, SafeStateError
from .instrument_lock import InstrumentLock
from .protocols import Clock, DeflectionSensor, HeaterOutput, SafeState


@dataclass
class Rig:
    """An open rig: the heater and sensor protocols, the clock, and what they were opened from."""

    heater: HeaterOutput
    sensor: DeflectionSensor
    clock: Clock
    config: RigConfig
    description: dict[str, Any]
    _closers: list[Callable[[], None]] = field(default_factory=list, repr=False)
    lock: InstrumentLock | None = field(default=None, repr=False)
    closed: bool = False
    #: What is known about the heater after the last :meth:`safe_state` (None: not asked yet).
    heater_state: SafeState | None = None

    @property
    def device(self) -> Any:
        """The simulated device the heater drives when the backend is the in-process simulator, else None
        (for inspection in tests and demos: its state, its true model, its faults)."""
        return getattr(self.heater, "device", None)

    def zero(self) -> None:
        """Heater to 0 V now (protected from Ctrl-C while on the wire); raises if the write fails."""
        with delay_keyboard_interrupt():
            self.heater.set_voltage(0.0)

    def safe_state(self) -> SafeState:
        """Heater to 0 V, and what is known afterwards (kept in :attr:`heater_state`); never raises a fault."""
        self.heater_state = self.heater.safe_state()
        return self.heater_state

    def close(self) -> None:
        """Heater to 0 V (confirmed, or :class:`SafeStateError`), then release the links and the lock.
        Idempotent."""
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
            if self.lock is not None:
                self.lock.release()
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
    device: Any = None,
) -> Rig:
    """Open the rig described by ``config`` (default: the built-in simulated device).

    ``clock`` overrides the configured one; ``device`` supplies the
    simulated device for ``driver = "sim"`` (the rig then uses its clock).
    Raises :class:`InstrumentBusy` if another run holds the instrument and
    :class:`ConnectionFailed` if it cannot be reached; nothing is written
    before the lock is held and the connection is up.
    """
    cfg = config if config is not None else default_config()
    if clock is None and device is not None:
        clock = device.clock
    clk = clock if clock is not None else make_clock(cfg.clock_kind)
    entry = cfg.backend
    address = entry.instrument_address(cfg)
    lock = InstrumentLock(address).acquire() if address is not None else None
    try:
        opened = entry.open(cfg, clk, device)
    except BaseException:
        if lock is not None:
            lock.release()
        raise
    description: dict[str, Any] = {"driver": cfg.driver, "name": cfg.name, "clock": getattr(clk, "kind", "custom"),
                                   **opened.description}
    rig = Rig(opened.heater, opened.sensor, clk, cfg, description, opened.closers, lock)
    try:
        rig.zero()
        rig.heater.verify()  # the instrument as it is now (its boot id) is the reference for reconnections
    except BaseException as exc:
        for close in opened.closers:
            close()
        if lock is not None:
            lock.release()
        if isinstance(exc, DeviceError) or not isinstance(exc, DriverError):
            raise
        raise type(exc)(f"the heater could not be set to 0 V on opening: {exc}") from exc
    return rig
