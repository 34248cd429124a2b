"""Physical parameters of the simulated VO2 microactuator (the ``[sim]`` table of ``rig.toml``).

The defaults describe a plausible bench in the spirit of the paper's
section 5.1:

* the heater (Au/Ti trace, 100 ohm) in series with an external resistor of
  682.5 ohm, so that the DAQ's 10 V full scale gives at most 12.78 mA, the
  paper's maximum current;
* a thermal resistance of 14.5 K/mW from the beam to the package
  (microcantilevers have 10^4 - 10^5 K/W): 6 V heats the beam by 85 K, from
  25 C to 110 C, well past the transition;
* VO2's insulator-to-metal transition centred at 68 C on heating (the
  paper: "at around 68 C") and 58 C on cooling (a 10 K wide loop, typical
  of VO2 films), each grain's transition temperature spread by 5 K;
* a phase-transition deflection of +-15 um, a bias of 2 um and a linear
  thermal term of -1.5 um/V (thermal expansion bends the beam the other
  way, paper section 5.2);
* a PSD of 5 um/V with 2 mV rms noise (0.01 um) and +-10 V rails;
* a first-order thermal time constant of 0.5 s.

The true Preisach model lives on ``levels`` uniform levels on
``[v_min_V, v_max_V]``; identification on the same grid can recover it
exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..configschema import setting
from .builtin_effects import make_effects


@dataclass(frozen=True, kw_only=True)
class SimParams:
    """Everything that defines a simulated device; see the module docstring for the defaults."""

    levels: int = setting("levels L of the true Preisach model's grid", default=30, minimum=1, maximum=400)
    v_min_V: float = setting("lowest wall of the true model's grid", default=0.0, unit="V", minimum=0.0)
    v_max_V: float = setting("highest wall of the true model's grid", default=6.0, unit="V", positive=True)
    ambient_C: float = setting("package (ambient) temperature", default=25.0, unit="C")
    heater_resistance_ohm: float = setting("resistance of the on-chip heater", default=100.0, unit="ohm", positive=True)
    series_resistance_ohm: float = setting(
        "external current-limiting resistor in series with the heater", default=682.5, unit="ohm", minimum=0.0
    )
    thermal_resistance_K_per_W: float = setting(
        "temperature rise of the beam per watt of heater power", default=14_500.0, unit="K/W", positive=True
    )
    time_constant_s: float = setting(
        "first-order thermal time constant (0: the temperature follows at once)",
        default=0.5, unit="s", minimum=0.0,
    )
    transition_heating_C: float = setting(
        "centre of the insulator-to-metal transition on heating", default=68.0, unit="C"
    )
    transition_cooling_C: float = setting(
        "centre of the metal-to-insulator transition on cooling", default=58.0, unit="C"
    )
    transition_width_C: float = setting(
        "standard deviation of the grains' transition temperatures", default=5.0, unit="C", positive=True
    )
    transition_amplitude_um: float = setting(
        "half the phase-transition deflection swing (sum of the cell weights)", default=15.0, unit="um"
    )
    bias_um: float = setting("bias mu0 of equation (22)", default=2.0, unit="um")
    thermal_um_per_V: float = setting("linear thermal term c_d of equation (22)", default=-1.5, unit="um/V")
    psd_um_per_V: float = setting("true PSD sensitivity of the simulated bench", default=5.0, unit="um/V", positive=True)
    psd_offset_V: float = setting("PSD output at zero deflection", default=0.0, unit="V")
    psd_noise_V: float = setting("rms Gaussian noise on each PSD reading", default=0.002, unit="V", minimum=0.0)
    psd_rail_V: float = setting("PSD output saturates at +-this voltage", default=10.0, unit="V", positive=True)
    max_output_V: float = setting(
        "the DAQ output's full scale: the device refuses larger |set-points|", default=10.0, unit="V", positive=True
    )
    seed: int = setting("seed of the PSD noise", default=0, minimum=0)
    effects: dict[str, Any] = setting(
        "extra physical effects, name = strength or a table (see drivers/sim/builtin_effects.py)",
        default_factory=dict,
    )

    def __post_init__(self) -> None:
        if not self.v_max_V > self.v_min_V:
            raise ValueError(f"v_max_V ({self.v_max_V}) must be above v_min_V ({self.v_min_V})")
        if self.v_max_V > self.max_output_V:
            raise ValueError(f"v_max_V ({self.v_max_V}) is beyond the output's full scale max_output_V")
        make_effects(self.effects)  # validates names and parameters

    @property
    def total_resistance_ohm(self) -> float:
        return self.heater_resistance_ohm + self.series_resistance_ohm

    @property
    def kelvin_per_V2(self) -> float:
        """Steady-state temperature rise per squared heater voltage: ``R_th R_h / (R_h + R_s)^2`` (K/V^2)."""
        return self.thermal_resistance_K_per_W * self.heater_resistance_ohm / self.total_resistance_ohm**2

    def steady_rise_K(self, volts: float) -> float:
        """Steady-state temperature rise (K) at heater voltage ``volts`` (V): Joule power times R_th."""
        return self.kelvin_per_V2 * volts * volts

    def equivalent_voltage(self, rise_K: float) -> float:
        """The voltage (V, >= 0) whose steady state is a rise of ``rise_K``: the inverse of :meth:`steady_rise_K`."""
        return (max(rise_K, 0.0) / self.kelvin_per_V2) ** 0.5

    def voltage_at(self, temperature_C: float) -> float:
        """Steady-state heater voltage (V) that holds the beam at ``temperature_C``."""
        return self.equivalent_voltage(temperature_C - self.ambient_C)

