"""Extra physical effects of the simulated device: the hook, and the registry they join.

The simulated device is a pipeline; every stage is a plain function of the
previous one, and every stage has a hook::

    heater voltage v --Joule, R_th--> steady rise --thermal lag--> rise (K)
        --[temperature_rise]--> rise'  --inverse static map--> v_eq (V)
        --[preisach_input]-->  x  --memory curve--> signed areas s
        --> u = mu0 + c_d v_eq + sum mu_ij s_ij      (equation (22))
        --[deflection]--> u'  --PSD calibration--> psd (V)
        --[psd]--> psd' --noise, rails--> reading

plus :meth:`Effect.on_setpoint` when a new voltage is applied (reversal
detection), :meth:`Effect.bind` once with the device's parameters, and
:meth:`Effect.state` for inspection.  Every hook defaults to
"no change", so an effect overrides only the stages it acts on.  An effect
is off unless its name appears in ``[sim.effects]`` with a non-zero
strength.

The effects (``thermal_lag``, ``baseline_drift``, ``ambient_drift``,
``joule_power``, ``creep``, ``sensor_nonlinearity``, ``gain_drift``) are in
:mod:`drivers.sim.builtin_effects`, with their registry, the tuple
:data:`~drivers.sim.builtin_effects.SIM_EFFECT_CLASSES`.  To add one, write
its class and add it to that tuple::

    class JoulePower(Effect):
        name = "joule_power"
        parameters = {}                       # extra keys and their defaults

        def deflection(self, um, moment):
            return um + self.strength * moment.voltage_V**2

Effects whose stage output is not monotone between two device events (for
example a drift that reverses the Preisach input while the heater is held)
set :attr:`Effect.max_step_s`; the device then advances in steps no longer
than that, updating the memory curve at each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar


@dataclass(frozen=True)
class Moment:
    """The device's state at one instant, as the hooks see it.

    ``t_s`` on the device's clock (s); ``voltage_V`` applied now;
    ``rise_K`` temperature rise above ambient after the thermal lag (for
    the ``preisach_input``, ``deflection`` and ``psd`` stages: after the
    ``temperature_rise`` hooks too, i.e. the beam's rise);
    ``temperature_C``; ``preisach_input_V`` the input of the memory curve
    (after the ``preisach_input`` hooks, once known, else ``nan``).
    """

    t_s: float
    voltage_V: float
    rise_K: float
    temperature_C: float
    preisach_input_V: float = math.nan


class Effect:
    """One extra effect with a ``strength`` (its units are the effect's own)."""

    #: Name in ``[sim.effects]``.
    name: ClassVar[str] = ""
    #: Extra parameters and their defaults, accepted in ``[sim.effects.NAME]``.
    parameters: ClassVar[dict[str, float]] = {}
    #: Longest step (s) the device may take without calling the hooks again.
    max_step_s: float = math.inf
    #: The strength ``rig demo`` switches it on with: a gap about ten times the noise on the default bench
    #: (``benchmarks/diagnose_bench.py`` calibrates it; rounded).
    demo_strength: ClassVar[float] = 0.0

    def __init__(self, strength: float, **params: float) -> None:
        self.strength = float(strength)
        for key, default in self.parameters.items():
            setattr(self, key, float(params.get(key, default)))
        self.reset()

    def bind(self, params: Any) -> None:
        """The device's :class:`~drivers.sim.params.SimParams`, given once when the device is built.

        For effects that need the device's own constants (the thermal
        resistance to turn a voltage into a temperature rise, ...).
        """

    def reset(self) -> None:
        """Back to the power-on state."""

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        """A new heater voltage was applied at ``t_s`` (after the device caught up to ``t_s``)."""

    def temperature_rise(self, rise_K: float, moment: Moment) -> float:
        """The beam's temperature rise (K) after the first-order lag."""
        return rise_K

    def preisach_input(self, volts: float, moment: Moment) -> float:
        """The memory curve's input (V, an equivalent heater voltage)."""
        return volts

    def deflection(self, um: float, moment: Moment) -> float:
        """The beam's deflection (um) from equation (22)."""
        return um

    def psd(self, volts: float, moment: Moment) -> float:
        """The PSD output (V) before noise and rails."""
        return volts

    def state(self) -> dict[str, Any]:
        """Internal state, for tests and inspection (JSON-safe)."""
        return {"strength": self.strength}
