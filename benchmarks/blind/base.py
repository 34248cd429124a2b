"""The base device every blind generator starts from: equation (22) on its grid, and the heater's thermal map.

This is the part of a simulated device that the model under test represents
exactly (a clean device leaves no gap); each blind generator adds its own
unmodelled mechanisms on top of it, written from the physical description in
``SPEC.md`` only.

Physics, in the rig's terms:

* The heater voltage ``v`` (V) drives a Joule power through the heater; at
  steady state the beam's temperature rise is ``rise_K(v) = kelvin_per_V2 * v**2``
  (K).  The beam's own thermal time constant is well under a second, so at the
  dwells used (seconds to minutes) the base device is at steady state.
* The VO2 film is a population of grains (hysterons), each switching to the
  metallic phase above its own temperature and back below a lower one.  Their
  thresholds are expressed in *equivalent heater volts*: the voltage whose
  steady state reaches that temperature (:meth:`BaseDevice.equivalent_voltage`).
  The film's deflection from the phase transition is ``phase = sum_cells
  density * signed_area``: the Preisach model on ``levels`` uniform levels of
  ``[v_min_V, v_max_V]``, the density uniform inside each cell.  A run starts
  from negative saturation (the heater at 0 V for a long time: every grain
  insulating, ``phase = -sum(density)``).
* The deflection is ``u = bias_um + thermal_um_per_V * v_thermal + phase(x)``:
  ``x`` is what the hysterons feel (the equivalent voltage of the film's
  temperature, ``v`` at steady state), ``v_thermal`` what the linear thermal
  expansion term follows (``v`` at steady state).

Units: V, K, C, um, s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivers.sim.params import SimParams
from drivers.sim.transition import transition_density
from identify.grid import Grid
from identify.memory import MemoryCurve

#: Levels of the base device's grid (the identification run's too).
LEVELS = 30


@dataclass(frozen=True, eq=False)
class BaseDevice:
    """One drawn device.  ``density_um`` ``(levels (levels + 1) / 2,)`` cell weights (um)."""

    levels: int
    v_min_V: float
    v_max_V: float
    density_um: np.ndarray
    bias_um: float
    thermal_um_per_V: float
    kelvin_per_V2: float
    ambient_C: float
    transition_heating_C: float
    transition_cooling_C: float
    transition_width_C: float

    @property
    def grid(self) -> Grid:
        return Grid(self.levels, self.v_min_V, self.v_max_V)

    @property
    def phase_swing_um(self) -> float:
        """Half the phase-transition swing: ``phase`` runs from ``-swing`` to ``+swing`` (um)."""
        return float(np.sum(self.density_um))

    def rise_K(self, v: float | np.ndarray) -> float | np.ndarray:
        """Steady-state temperature rise (K) of the beam at heater voltage ``v`` (V)."""
        return self.kelvin_per_V2 * np.square(v)

    def equivalent_voltage(self, rise_K: float | np.ndarray) -> float | np.ndarray:
        """The heater voltage (V, >= 0) whose steady state is a rise of ``rise_K`` (K)."""
        return np.sqrt(np.maximum(rise_K, 0.0) / self.kelvin_per_V2)

    def hysteresis(self) -> "Hysteresis":
        """The film's phase transition, in negative saturation."""
        return Hysteresis(self)

    def output(self, phase_um: float, v_thermal: float) -> float:
        """Equation (22)'s deflection (um) given the phase part and what the thermal term follows (V)."""
        return self.bias_um + self.thermal_um_per_V * v_thermal + phase_um


class Hysteresis:
    """The phase-transition part of the deflection (um) with its memory.

    ``peek(x)``: the phase part if the hysterons' input moved to ``x`` (V) now,
    without moving it; ``move(x)``: move it and return the phase part;
    ``copy()``: an independent copy with the same memory.  Inputs outside the
    grid saturate.
    """

    def __init__(self, device: BaseDevice) -> None:
        self.device = device
        self._grid = device.grid
        self._curve = MemoryCurve(device.levels)
        self._x = device.v_min_V

    @property
    def position(self) -> float:
        """The input (V) the hysterons last felt."""
        return self._x

    def copy(self) -> "Hysteresis":
        other = Hysteresis.__new__(Hysteresis)
        other.device, other._grid, other._x = self.device, self._grid, self._x
        other._curve = self._curve.copy()
        return other

    def _phase(self, curve: MemoryCurve) -> float:
        return float(self.device.density_um @ curve.signed_areas(self._grid))

    def peek(self, x: float) -> float:
        curve = self._curve.copy()
        curve.apply(float(self._grid.coordinates(np.array([float(x)]))[0]))
        return self._phase(curve)

    def move(self, x: float) -> float:
        self._curve.apply(float(self._grid.coordinates(np.array([float(x)]))[0]))
        self._x = float(x)
        return self._phase(self._curve)

    def value(self) -> float:
        """The phase part at the current memory (um)."""
        return self._phase(self._curve)


def _stream(seed: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([20_261_127, int(seed), 1]))


def draw_device(seed: int) -> BaseDevice:
    """A physically plausible VO2 actuator (ranges as on the bench), drawn from ``seed``."""
    rng = _stream(seed)
    heating = float(rng.uniform(62.0, 74.0))
    params = SimParams(
        levels=LEVELS,
        ambient_C=float(rng.uniform(20.0, 30.0)),
        transition_heating_C=heating,
        transition_cooling_C=heating - float(rng.uniform(5.0, 15.0)),
        transition_width_C=float(rng.uniform(2.5, 7.0)),
        transition_amplitude_um=float(rng.uniform(8.0, 20.0)),
        bias_um=float(rng.uniform(-3.0, 5.0)),
        thermal_um_per_V=float(rng.uniform(-3.0, -0.3)),
        thermal_resistance_K_per_W=float(rng.uniform(12_000.0, 17_000.0)),
    )
    grid = Grid(params.levels, params.v_min_V, params.v_max_V)
    return BaseDevice(
        levels=params.levels, v_min_V=params.v_min_V, v_max_V=params.v_max_V,
        density_um=transition_density(grid, params), bias_um=params.bias_um,
        thermal_um_per_V=params.thermal_um_per_V, kelvin_per_V2=params.kelvin_per_V2,
        ambient_C=params.ambient_C, transition_heating_C=params.transition_heating_C,
        transition_cooling_C=params.transition_cooling_C, transition_width_C=params.transition_width_C,
    )


def clean_outputs(device: BaseDevice, v_V: np.ndarray) -> np.ndarray:
    """The clean device's deflection (um) at each set-point of ``v_V`` ``(n,)``, at steady state."""
    h = device.hysteresis()
    return np.array([device.output(h.move(v), v) for v in np.asarray(v_V, dtype=float)])


__all__ = ["LEVELS", "BaseDevice", "Hysteresis", "clean_outputs", "draw_device"]
