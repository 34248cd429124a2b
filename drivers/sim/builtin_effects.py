"""The unmodelled effects of the simulated VO2 actuator: physics that equation (22) leaves out.

Each is off by default and switched on in ``[sim.effects]`` with a
strength in its own unit (below).  They are written as *device physics*
-- temperatures, powers, PSD volts, the device's own clock -- and share no
code with the candidate augmentations of :mod:`identify.diagnosis`, which
model the same effects in other functional forms from what a session
records.  A diagnosis that recognises these effects through those
candidates therefore says something about real data, not about a shared
formula.

=======================  ===========  ==============================================================
name                     strength     what it does (stage)
=======================  ===========  ==============================================================
``thermal_lag``          1 (fraction) a slow thermal mode (chip and package) holds this fraction of
                                      the steady temperature rise; relaxes with ``time_constant_s``
                                      (``temperature_rise``)
``baseline_drift``       V (rms)      the PSD zero wanders: laser pointing, mechanics
                                      (``psd``)
``ambient_drift``        K (rms)      the room (package) temperature wanders, moving where the
                                      transition happens (``preisach_input``)
``joule_power``          um/K         a thermal-expansion deflection that follows the beam's
                                      temperature rise, i.e. heater power (``deflection``)
``creep``                um/V         after each reversal the deflection is offset in proportion to
                                      the excursion just ended and relaxes as a stretched
                                      exponential of the time since (``deflection``)
``sensor_nonlinearity``  1/V          the PSD saturates: ``c + V_s tanh((psd - c) / V_s)`` with
                                      ``V_s = 1 / strength`` (``psd``)
``gain_drift``           1 (rms)      the PSD's sensitivity wanders: the signal about the sensor's
                                      zero is scaled by ``1 + strength d(t)`` (``psd``)
=======================  ===========  ==============================================================

Physical justification, one line each: a micro-heater heats the beam in
well under a second but the chip and package around it in seconds to
minutes, so part of the rise arrives late (a linear thermal network is a
sum of such modes); laser pointing and mount relaxation move the spot on
the detector independently of the beam; the package sits on a bench whose
temperature follows the room; thermal expansion is proportional to
temperature, which Joule heating makes proportional to ``v^2``, while
equation (22) uses ``c_d v``; the laser's power and the lever's alignment
drift, which changes the detector's sensitivity, not its zero; the strain of a phase transition relaxes
slowly (thermally activated, with a broad spread of rates -- hence a
stretched exponential) after the transition changes direction; and a
lateral-effect PSD is linear only near its centre.

The drifts are smooth random processes -- a few sinusoids with periods
log-uniform between ``period_min_s`` and ``period_max_s``, amplitudes
growing with the period (a red spectrum), random phases, unit rms --
seeded by the effect's ``seed``: give two runs different seeds and their
drifts differ, as on a real bench from one run to the next.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from identify.registry import ByName

from .effect_hooks import Effect, Moment

#: Sinusoids in a drift realisation.
DRIFT_COMPONENTS = 4
#: A creep transient below this fraction of its start is dropped.
CREEP_CUTOFF = 1e-9


class SmoothDrift:
    """A smooth zero-mean random function of time with unit rms (see the module doc)."""

    def __init__(self, seed: int, period_min_s: float, period_max_s: float, salt: int) -> None:
        if not 0 < period_min_s <= period_max_s:
            raise ValueError(f"drift periods must satisfy 0 < period_min_s <= period_max_s, "
                             f"got {period_min_s}, {period_max_s}")
        rng = np.random.default_rng([int(seed), salt])
        self.periods = np.exp(rng.uniform(math.log(period_min_s), math.log(period_max_s), DRIFT_COMPONENTS))
        self.phases = rng.uniform(0.0, 2.0 * math.pi, DRIFT_COMPONENTS)
        amp = self.periods / self.periods.max()
        self.amplitudes = amp * math.sqrt(2.0 / np.sum(amp**2))  # mean square of the sum: 1

    def __call__(self, t_s: float) -> float:
        return float(np.sum(self.amplitudes * np.sin(2.0 * math.pi * t_s / self.periods + self.phases)))


class ThermalLag(Effect):
    """A slow thermal mode: ``strength`` (0..1) of the steady rise arrives with ``time_constant_s``.

    The beam's rise is ``(1 - a) r_fast + a r_slow``: ``r_fast`` the device's
    own first-order lag (``sim.time_constant_s``), ``r_slow`` relaxing
    towards the same steady rise ``R_th P(v)`` with the slower time
    constant -- the modal form of a two-node thermal network.  The steady
    state is unchanged, so equation (22) still holds after a long dwell;
    a dwell of a few ``time_constant_s`` or less measures the beam short of
    its set-point temperature.
    """

    name = "thermal_lag"
    demo_strength = 0.035
    parameters = {"time_constant_s": 5.0}

    def __init__(self, strength: float, **params: float) -> None:
        super().__init__(strength, **params)
        if not 0.0 < self.strength <= 1.0:
            raise ValueError(f"thermal_lag strength is a fraction of the rise in (0, 1], got {self.strength}")
        if not self.time_constant_s > 0:
            raise ValueError(f"thermal_lag time_constant_s must be positive, got {self.time_constant_s}")
        # the blend of two modes moving at different rates is not monotone between events
        self.max_step_s = self.time_constant_s / 10.0
        self._params: Any = None

    def bind(self, params: Any) -> None:
        self._params = params

    def reset(self) -> None:
        self._t: float | None = None
        self._slow = 0.0
        self._target = 0.0

    def _advance(self, t_s: float) -> None:
        if self._t is not None and t_s > self._t:
            decay = math.exp(-(t_s - self._t) / self.time_constant_s)
            self._slow = self._target + (self._slow - self._target) * decay
        self._t = t_s if self._t is None else max(self._t, t_s)

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        self._advance(t_s)
        self._target = self._params.steady_rise_K(new_V)

    def temperature_rise(self, rise_K: float, moment: Moment) -> float:
        self._advance(moment.t_s)
        return (1.0 - self.strength) * rise_K + self.strength * self._slow

    def state(self) -> dict[str, Any]:
        return {"strength": self.strength, "slow_rise_K": self._slow, "target_rise_K": self._target}


class BaselineDrift(Effect):
    """The PSD zero wanders by ``strength`` volts rms (a smooth random drift, see the module doc)."""

    name = "baseline_drift"
    demo_strength = 0.009
    parameters = {"seed": 0.0, "period_min_s": 1800.0, "period_max_s": 14400.0}

    def __init__(self, strength: float, **params: float) -> None:
        super().__init__(strength, **params)
        self._drift = SmoothDrift(int(self.seed), self.period_min_s, self.period_max_s, salt=1)

    def psd(self, volts: float, moment: Moment) -> float:
        return volts + self.strength * self._drift(moment.t_s)


class GainDrift(Effect):
    """The PSD's sensitivity wanders by ``strength`` (relative, rms): the signal about the sensor's zero
    (``psd_offset_V``, the PSD output at zero deflection) is scaled by ``1 + strength d(t)``, ``d`` a smooth
    random drift of unit rms (see the module doc)."""

    name = "gain_drift"
    demo_strength = 0.004
    parameters = {"seed": 0.0, "period_min_s": 1800.0, "period_max_s": 14400.0}

    def __init__(self, strength: float, **params: float) -> None:
        super().__init__(strength, **params)
        self._drift = SmoothDrift(int(self.seed), self.period_min_s, self.period_max_s, salt=3)
        self._zero_V = 0.0

    def bind(self, params: Any) -> None:
        self._zero_V = float(params.psd_offset_V)

    def psd(self, volts: float, moment: Moment) -> float:
        return self._zero_V + (volts - self._zero_V) * (1.0 + self.strength * self._drift(moment.t_s))


class AmbientDrift(Effect):
    """The package temperature wanders by ``strength`` kelvin rms around ``sim.ambient_C``.

    The phase transition happens at a fixed absolute temperature, so the
    Preisach input -- the equivalent heater voltage of the beam's
    temperature -- becomes the voltage whose steady rise equals the actual
    rise plus the ambient change: ``sqrt((rise + dT) / k)``.  The shift in
    volts is therefore larger at low voltages, where the transition is not.
    The thermal-expansion term keeps following the heater (the effect acts
    on the input of the memory curve only).  The input moves while the
    heater is held, so the device steps at most ``period_min_s / 100``.
    """

    name = "ambient_drift"
    demo_strength = 0.046
    parameters = {"seed": 0.0, "period_min_s": 1800.0, "period_max_s": 14400.0}

    def __init__(self, strength: float, **params: float) -> None:
        super().__init__(strength, **params)
        self._drift = SmoothDrift(int(self.seed), self.period_min_s, self.period_max_s, salt=2)
        self.max_step_s = self.period_min_s / 100.0
        self._params: Any = None

    def bind(self, params: Any) -> None:
        self._params = params

    def preisach_input(self, volts: float, moment: Moment) -> float:
        p = self._params
        shift = self.strength * self._drift(moment.t_s)
        return volts + p.equivalent_voltage(moment.rise_K + shift) - p.equivalent_voltage(moment.rise_K)


class JoulePower(Effect):
    """Thermal expansion in proportion to the beam's temperature rise: ``strength`` um per kelvin.

    The rise follows heater power, ``R_th R_h v^2 / (R_h + R_s)^2``
    (through the thermal lags), so this term is quadratic in the heater
    voltage where equation (22)'s ``c_d v`` is linear.
    """

    name = "joule_power"
    demo_strength = 0.093

    def deflection(self, um: float, moment: Moment) -> float:
        return um + self.strength * moment.rise_K


class Creep(Effect):
    """Relaxation after each reversal: ``strength`` um per volt of the excursion just ended.

    When the heater turns back at ``t_r`` after an excursion of ``E_r``
    volts (from the previous turning point, or from 0 V at power-on, to
    the point where it turned), the deflection gains
    ``strength * E_r * exp(-((t - t_r) / time_constant_s) ** stretch)``,
    which decays with the time since the reversal; the transients of all
    reversals add up.
    """

    name = "creep"
    demo_strength = 0.06
    parameters = {"time_constant_s": 60.0, "stretch": 0.5}

    def __init__(self, strength: float, **params: float) -> None:
        super().__init__(strength, **params)
        if not self.time_constant_s > 0:
            raise ValueError(f"creep time_constant_s must be positive, got {self.time_constant_s}")
        if not 0.0 < self.stretch <= 1.0:
            raise ValueError(f"creep stretch must be in (0, 1], got {self.stretch}")
        self._horizon_s = self.time_constant_s * (-math.log(CREEP_CUTOFF)) ** (1.0 / self.stretch)

    def reset(self) -> None:
        self._direction = 0
        self._turning_V = 0.0  # the device powers on at 0 V
        self._events: list[tuple[float, float]] = []  # (t_r, excursion in V)

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        direction = (new_V > old_V) - (new_V < old_V)
        if direction == 0:
            return
        if self._direction and direction != self._direction:
            self._events.append((t_s, old_V - self._turning_V))
            self._turning_V = old_V
        self._direction = direction
        self._events = [(t, e) for t, e in self._events if t_s - t < self._horizon_s]

    def deflection(self, um: float, moment: Moment) -> float:
        t = moment.t_s
        total = 0.0
        for t_r, excursion in self._events:
            if t >= t_r:
                total += excursion * math.exp(-(((t - t_r) / self.time_constant_s) ** self.stretch))
        return um + self.strength * total

    def state(self) -> dict[str, Any]:
        return {"strength": self.strength, "reversals": len(self._events)}


class SensorNonlinearity(Effect):
    """A saturating PSD: ``c + V_s tanh((psd - c) / V_s)`` with ``V_s = 1 / strength`` volts.

    ``centre_V`` is the PSD output where the response is steepest (the
    spot at the detector's centre).  For small ``strength`` the reading is
    ``psd - strength^2 (psd - c)^3 / 3``: mild and odd about the centre.
    """

    name = "sensor_nonlinearity"
    demo_strength = 0.24
    parameters = {"centre_V": 0.0}

    def psd(self, volts: float, moment: Moment) -> float:
        s, c = self.strength, self.centre_V
        return c + math.tanh((volts - c) * s) / s


#: The simulated device's effects, in the order ``[sim.effects]`` lists them: the registry (one line per effect).
SIM_EFFECT_CLASSES: tuple[type[Effect], ...] = (ThermalLag, BaselineDrift, GainDrift, AmbientDrift, JoulePower, Creep,
                                                SensorNonlinearity)
#: The effects by name (:data:`SIM_EFFECT_CLASSES`, read at each use).
EFFECTS: ByName[type[Effect]] = ByName(lambda: SIM_EFFECT_CLASSES)


def make_effects(table: dict[str, Any], registry: dict[str, type[Effect]] | None = None) -> list[Effect]:
    """Effects from the ``[sim.effects]`` table: ``name = strength`` or ``[sim.effects.name]``.

    A zero strength leaves the effect off.  Raises :class:`ValueError`
    naming the key for an unknown effect or parameter.
    """
    registry = EFFECTS if registry is None else registry
    out: list[Effect] = []
    for name, spec in table.items():
        if name not in registry:
            known = ", ".join(sorted(registry)) or "none yet"
            raise ValueError(f"unknown effect 'sim.effects.{name}' (available: {known})")
        cls = registry[name]
        if isinstance(spec, dict):
            params = dict(spec)
            if "strength" not in params:
                raise ValueError(f"missing key 'sim.effects.{name}.strength'")
            strength = params.pop("strength")
        else:
            strength, params = spec, {}
        for key, value in [("strength", strength), *params.items()]:
            if key != "strength" and key not in cls.parameters:
                raise ValueError(f"unknown key 'sim.effects.{name}.{key}'")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"key 'sim.effects.{name}.{key}' must be a finite number")
        if strength:
            out.append(cls(strength, **params))
    return out
