"""``[heater]`` and ``[sensor]``: the tables of ``rig.toml`` every backend reads, whatever its transport.

The heater output's limits (checked before anything is written) and the
PSD's calibration; each backend's own table is declared by its package
(:mod:`drivers.modbus.config`, :mod:`drivers.serial.config`,
:mod:`drivers.sim.params`) and :mod:`drivers.config` assembles them.
"""

from __future__ import annotations

from dataclasses import dataclass

from .configschema import setting
from .limits import HeaterLimits
from .protocols import Calibration


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
