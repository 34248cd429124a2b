"""The simulated VO2 microactuator: heater voltage in, PSD voltage out, in simulated physics.

Pipeline (see :mod:`drivers.sim.effect_hooks` for the hooks at every stage):

1. Joule heating: ``P = R_h (v / (R_h + R_s))^2``; steady temperature rise
   ``R_th P`` (K).
2. First-order thermal lag with time constant ``tau``: the rise relaxes
   exponentially towards its steady value, in closed form over any interval
   of the device's clock (a virtual clock makes an hour of dwell free).
3. The Preisach input is the *equivalent voltage* of the current rise --
   the voltage whose steady state it is -- so that at steady state it is the
   heater voltage itself, the input of the paper's equation (22).  Between
   two events (a set-point change, a reading) the rise moves monotonically,
   so updating the memory curve at the events is exact.
4. Deflection ``u = mu0 + c_d v_eq + sum mu_ij s_ij`` (equation (22)) with
   the transition density of :mod:`drivers.sim.transition`.
5. PSD: ``u / psd_um_per_V + psd_offset_V`` plus seeded Gaussian noise,
   clipped at the rails.

With a dwell much longer than ``tau`` (about 37 tau or more, where the lag
is below double precision) and no extra effects the device reproduces
:meth:`SimVO2.true_model` -- equation (22) -- exactly; the tests check it
on arbitrary inputs.  Cost per reading: a few microseconds plus the cells
whose signed area changed (one row or column of cells per wall crossed).
"""

from __future__ import annotations

import math
import numbers
import secrets
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from identify import Grid, MemoryCurve, PreisachModel
from identify.memory import CellStates

from ..clock import VirtualClock
from ..configschema import as_dict
from ..errors import SetpointRefused
from ..protocols import Clock
from .builtin_effects import make_effects
from .effect_hooks import Effect, Moment
from .faults import FaultPlan
from .params import SimParams
from .transition import transition_density


class DeviceRefused(SetpointRefused):
    """The simulated hardware refuses a set-point (not finite, or beyond its full scale)."""


@dataclass(frozen=True)
class SimState:
    """A snapshot of the device, for tests and inspection.

    ``memory`` is a copy of the memory curve (grid coordinates of the true
    model's grid; compare two states with ``==``); ``signed_areas`` has
    shape ``(n_cells,)``.
    """

    t_s: float
    voltage_V: float
    rise_K: float
    temperature_C: float
    settled: bool
    preisach_input_V: float
    memory: MemoryCurve
    signed_areas: np.ndarray
    phase_um: float
    thermal_um: float
    deflection_um: float
    effects: dict[str, Any] = field(default_factory=dict)


class SimVO2:
    """The simulated device.  Thread-safe; all times are on ``clock``."""

    def __init__(
        self,
        params: SimParams | None = None,
        clock: Clock | None = None,
        *,
        effects: list[Effect] | None = None,
        faults: FaultPlan | None = None,
        setpoint_log_size: int = 100_000,
    ) -> None:
        self.params = params if params is not None else SimParams()
        self.clock: Clock = clock if clock is not None else VirtualClock()
        self.grid = Grid(self.params.levels, self.params.v_min_V, self.params.v_max_V)
        #: Cell weights of the phase transition (um), shape ``(n_cells,)``.
        self.density = transition_density(self.grid, self.params)
        self.effects: list[Effect] = list(effects) if effects is not None else make_effects(self.params.effects)
        for e in self.effects:
            e.bind(self.params)
        self.faults = faults if faults is not None else FaultPlan()
        #: Every accepted set-point as ``(t_s, volts)``, oldest first.
        self.setpoints: deque[tuple[float, float]] = deque(maxlen=setpoint_log_size)
        self._lock = threading.RLock()
        self._max_step = min((e.max_step_s for e in self.effects), default=math.inf)
        self.reset()

    # ------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Power-cycle: ambient temperature, 0 V, negative saturation, noise re-seeded, a new :attr:`boot_id`."""
        with self._lock:
            #: A random 32-bit number drawn at every power-up: a client that reads a different one after
            #: reconnecting knows the instrument restarted (and lost its output and the beam's memory state).
            self.boot_id = secrets.randbits(32)
            self._rng = np.random.default_rng(self.params.seed)
            self._t = self.clock.now()
            self._v = 0.0
            self._rise = 0.0
            self._beam_rise = 0.0
            self._target = 0.0
            self._settled = True
            self._v_eq = 0.0
            self._x_in = 0.0
            self._states = CellStates(self.grid, MemoryCurve(self.grid.levels, "negative"))
            self.setpoints.clear()
            for e in self.effects:
                e.reset()

    def true_model(self) -> PreisachModel:
        """The model this device follows at steady state (equation (22), no extra effects)."""
        return PreisachModel(
            self.grid,
            self.density,
            mu0=self.params.bias_um,
            c_d=self.params.thermal_um_per_V,
            metadata={"source": "drivers.sim.SimVO2", "params": as_dict(self.params)},
        )

    # ------------------------------------------------------------ the instrument
    def apply_voltage(self, volts: float) -> None:
        """Set the heater voltage (V) now; refuses NaN, infinities and |v| > ``max_output_V``."""
        if isinstance(volts, bool) or not isinstance(volts, numbers.Real):
            raise DeviceRefused(f"set-point {volts!r} is not a number")
        v = float(volts)
        if not math.isfinite(v) or abs(v) > self.params.max_output_V:
            raise DeviceRefused(
                f"set-point {v} V refused: outside the output's +-{self.params.max_output_V:g} V"
            )
        with self._lock:
            t = self.clock.now()
            self._advance(t)
            old = self._v
            self._v = v
            self._target = self.params.steady_rise_K(v)
            self._settled = self._rise == self._target
            self.setpoints.append((t, v))
            for e in self.effects:
                e.on_setpoint(t, old, v)
            if self.params.time_constant_s == 0.0:
                self._rise, self._settled = self._target, True
                self._update_memory()

    @property
    def applied_voltage(self) -> float:
        """The heater voltage being applied (V)."""
        return self._v

    def read_psd(self) -> float:
        """One PSD reading (V) now: deflection, calibration, noise, rails (and injected faults)."""
        with self._lock:
            self._advance(self.clock.now())
            if self.faults.take("nan_readings"):
                return math.nan
            p = self.params
            psd = self._deflection() / p.psd_um_per_V + p.psd_offset_V
            if self.effects:
                m = self._moment()
                for e in self.effects:
                    psd = e.psd(psd, m)
            if p.psd_noise_V:
                psd += p.psd_noise_V * self._rng.standard_normal()
            if self.faults.take("saturated_readings"):
                psd = p.psd_rail_V
            return min(max(psd, -p.psd_rail_V), p.psd_rail_V)

    def deflection_um(self) -> float:
        """The noise-free deflection (um) now."""
        with self._lock:
            self._advance(self.clock.now())
            return self._deflection()

    def state(self) -> SimState:
        """A snapshot now (advances the device to the clock's time first)."""
        with self._lock:
            self._advance(self.clock.now())
            areas = self._states.areas
            phase = float(areas @ self.density)
            thermal = self.params.thermal_um_per_V * self._v_eq
            return SimState(
                t_s=self._t,
                voltage_V=self._v,
                rise_K=self._rise,
                temperature_C=self.params.ambient_C + self._rise,
                settled=self._settled,
                preisach_input_V=self._x_in,
                memory=self._states.curve.copy(),
                signed_areas=areas.copy(),
                phase_um=phase,
                thermal_um=thermal,
                deflection_um=self._deflection(),
                effects={e.name: e.state() for e in self.effects},
            )

    # ------------------------------------------------------------ physics
    def _moment(self) -> Moment:
        rise = self._beam_rise
        return Moment(self._t, self._v, rise, self.params.ambient_C + rise, self._x_in)

    def _advance(self, t: float) -> None:
        """Evolve the temperature from the last event to ``t`` and update the memory curve."""
        dt = t - self._t
        if dt <= 0.0:
            return
        if self._max_step == math.inf:
            self._relax(dt)
            self._t = t
            self._update_memory()
            return
        n = max(1, math.ceil(dt / self._max_step))
        start = self._t
        for k in range(1, n + 1):
            self._relax(dt / n)
            self._t = start + dt * k / n
            self._update_memory()
        self._t = t

    def _relax(self, dt: float) -> None:
        """First-order lag of the temperature rise over ``dt`` seconds."""
        if self._settled:
            return
        tau = self.params.time_constant_s
        decay = math.exp(-dt / tau) if tau > 0 else 0.0
        if decay < 1e-17:  # below double precision: exactly settled
            self._rise, self._settled = self._target, True
        else:
            self._rise = self._target + (self._rise - self._target) * decay

    def _update_memory(self) -> None:
        rise = self._rise
        if self.effects:
            m = Moment(self._t, self._v, rise, self.params.ambient_C + rise, self._x_in)
            for e in self.effects:
                rise = e.temperature_rise(rise, m)
        # Settled and untouched: the equivalent voltage is the set-point itself, exactly.
        exact = self._settled and rise == self._target
        v_eq = abs(self._v) if exact else self.params.equivalent_voltage(rise)
        x_in = v_eq
        if self.effects:
            m = Moment(self._t, self._v, rise, self.params.ambient_C + rise)
            for e in self.effects:
                x_in = e.preisach_input(x_in, m)
        self._v_eq, self._x_in, self._beam_rise = v_eq, x_in, rise
        self._states.apply(float(self.grid.coordinates(x_in)))

    def _deflection(self) -> float:
        p = self.params
        # Summed in the order of PreisachModel.predict, so a settled device matches it bit for bit.
        u = (float(self._states.areas @ self.density) + p.bias_um) + p.thermal_um_per_V * self._v_eq
        if self.effects:
            m = self._moment()
            for e in self.effects:
                u = e.deflection(u, m)
        return u
