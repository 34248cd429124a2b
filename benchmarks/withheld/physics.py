"""Withheld physics: effect families drawn at random, and the simulated device that carries them.

Every effect here was written from a physical description of the mechanism
only (issue 15), without reading the diagnosis code nor the simulator's
built-in effects.  An effect *family* is a mechanism; a *form* is one
member of it, drawn at random by :func:`draw_form` from a seeded generator
(kernel, shape, time constants, sign...) and recorded as a JSON-safe dict;
the *strength* is one positive number, calibrated later
(:mod:`benchmarks.withheld.generate`) so that the effect opens a given gap.
Anything that should differ from run to run (a drift's realisation) is
drawn from a per-run generator when the effect is built for that run.

Effects plug into the hooks of :mod:`drivers.sim.effect_hooks` (voltage ->
rise -> Preisach input -> deflection -> PSD).  Two mechanisms need more
than the hooks give, and get it from :class:`WithheldVO2`, a small
subclass of :class:`drivers.sim.SimVO2`:

* the mean-field ``interaction`` needs the hysterons' state to solve
  ``x = v + k u(x)`` self-consistently (:meth:`WithheldVO2.phase_after`);
* the ``backlash`` of the optical lever needs the deflection *along* the
  path between two device events, not only at its ends
  (:meth:`WithheldVO2._update_memory` samples it for effects that ask).

Units: times in s on the device's clock (power-on at 0), voltages in V,
deflections in um, temperatures in K.  See ``README.md`` for the families.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import brentq

from drivers.sim import Effect, SimParams, SimVO2
from drivers.sim.effect_hooks import Moment
from identify import PreisachModel
from identify.memory import CellStates

#: Names the diagnosis library is meant to cover.
LIBRARY = ("thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
           "sensor_nonlinearity", "reversible", "interaction", "first_point")
#: Mechanisms held out of the library entirely.
OUTSIDE = ("backlash", "accommodation", "gain_drift")
#: Pipeline order when several effects act at once (each stage applies its hooks in this order).
ORDER = ("thermal_lag", "ambient_drift", "interaction", "joule_power", "reversible", "accommodation",
         "creep", "backlash", "first_point", "sensor_nonlinearity", "baseline_drift", "gain_drift")

#: A session lasts about three hours; slow shapes are normalised over this span (s).
SESSION_S = 3 * 3600.0


# ====================================================================== helpers
def loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def pick(rng: np.random.Generator, options: tuple[str, ...]) -> str:
    return options[int(rng.integers(len(options)))]


class RandomSmooth:
    """A stationary Gaussian-process draw of unit variance (random Fourier features).

    ``kernel`` is ``squared_exponential``, ``matern32`` or ``matern52``;
    ``length`` its correlation length in the units of the argument.
    """

    def __init__(self, rng: np.random.Generator, length: float, kernel: str, features: int = 64) -> None:
        z = rng.standard_normal(features)
        if kernel == "squared_exponential":
            omega = z / length
        else:
            nu = {"matern32": 1.5, "matern52": 2.5}[kernel]
            omega = z * np.sqrt(2 * nu / rng.chisquare(2 * nu, features)) / length
        self.omega = omega
        self.phase = rng.uniform(0.0, 2 * math.pi, features)
        self.scale = math.sqrt(2.0 / features)

    def __call__(self, t: float | np.ndarray) -> float | np.ndarray:
        arg = np.multiply.outer(np.asarray(t, dtype=float), self.omega) + self.phase
        out = self.scale * np.cos(arg).sum(axis=-1)
        return float(out) if np.ndim(out) == 0 else out


# ====================================================================== slow shapes
SLOW_KINDS = ("smooth_random", "warmup", "trend", "oscillation")


def draw_slow_shape(rng: np.random.Generator) -> dict[str, Any]:
    """A slow shape of session time: one or two components (the case's; realised per run)."""
    n = 1 if rng.random() < 0.6 else 2
    kinds = [SLOW_KINDS[i] for i in rng.choice(len(SLOW_KINDS), n, replace=False)]
    comps = []
    for kind in kinds:
        c: dict[str, Any] = {"kind": kind, "weight": 1.0 if n == 1 else float(rng.uniform(0.3, 1.0))}
        if kind == "smooth_random":
            c.update(kernel=pick(rng, ("squared_exponential", "matern32", "matern52")),
                     corr_time_s=loguniform(rng, 900.0, 14_400.0))
        elif kind == "warmup":
            c.update(sign=float(rng.choice([-1.0, 1.0])), tau_s=loguniform(rng, 120.0, 3600.0))
        elif kind == "trend":
            c.update(sign=float(rng.choice([-1.0, 1.0])), curvature=float(rng.uniform(-0.6, 0.6)))
        else:
            c.update(period_s=loguniform(rng, 1200.0, 10_800.0), harmonic=float(rng.uniform(0.0, 0.4)))
        comps.append(c)
    return {"components": comps}


class SlowCurve:
    """One run's realisation of a slow shape: ``f(t)``, of order one over a session, ``f(0) = 0``."""

    def __init__(self, shape: dict[str, Any], rng: np.random.Generator) -> None:
        parts: list[Callable[[float], float]] = []
        for c in shape["components"]:
            w = float(c["weight"])
            kind = c["kind"]
            if kind == "smooth_random":
                g = RandomSmooth(rng, float(c["corr_time_s"]), str(c["kernel"]))
                parts.append(lambda t, g=g, w=w: w * g(t))
            elif kind == "warmup":
                amp = c["sign"] * (1.0 + 0.25 * rng.standard_normal())
                tau = c["tau_s"] * math.exp(0.2 * rng.standard_normal())
                parts.append(lambda t, a=amp, tau=tau, w=w: w * a * (1.0 - math.exp(-t / tau)))
            elif kind == "trend":
                slope = c["sign"] + 0.5 * rng.standard_normal()
                curv = c["curvature"] * (1.0 + 0.3 * rng.standard_normal())
                parts.append(lambda t, s=slope, q=curv, w=w: w * (s * t / SESSION_S + q * (t / SESSION_S) ** 2))
            else:
                amp = 1.0 + 0.2 * rng.standard_normal()
                p1, p2 = rng.uniform(0.0, 2 * math.pi, 2)
                om = 2 * math.pi / c["period_s"]
                h = c["harmonic"]
                parts.append(lambda t, a=amp, p1=p1, p2=p2, om=om, h=h, w=w:
                             w * a * (math.sin(om * t + p1) + h * math.sin(2 * om * t + p2)))
        self._parts = parts
        self._zero = sum(p(0.0) for p in parts)

    def __call__(self, t: float) -> float:
        return sum(p(t) for p in self._parts) - self._zero


# ====================================================================== the device
class WithheldVO2(SimVO2):
    """:class:`SimVO2` whose effects may look at the hysterons and at the path between events.

    Effects with an ``attach(device)`` method get the device once built.
    Effects with ``wants_path = True`` get ``on_path(outputs_um)``: the
    deflection of equation (22) sampled along the (monotone) move of the
    input between two device events, before the move is applied.
    """

    PATH_SAMPLES = 12

    def __init__(self, params: SimParams, clock: Any = None, *, effects: list[Effect] | None = None) -> None:
        super().__init__(params, clock, effects=list(effects or []))
        self.amplitude_um = float(np.abs(self.density).sum())
        self._path_effects = [e for e in self.effects if getattr(e, "wants_path", False)]
        self._turning_effects = [e for e in self.effects if hasattr(e, "turning_points")]
        for e in self.effects:
            if hasattr(e, "attach"):
                e.attach(self)

    # -------------------------------------------------------- for the effects
    def phase_um(self) -> float:
        """Phase-transition part of the deflection now (um): ``sum mu_ij s_ij``."""
        return float(self._states.areas @ self.density)

    def _trial_states(self) -> CellStates:
        st = CellStates.__new__(CellStates)
        st.grid, st.curve, st.areas = self.grid, self._states.curve.copy(), self._states.areas.copy()
        return st

    def phase_after(self, x_V: float) -> float:
        """The phase part (um) if the input moved monotonically from where it is to ``x_V`` now (no change made)."""
        st = self._trial_states()
        return float(st.apply(float(self.grid.coordinates(x_V))) @ self.density)

    # -------------------------------------------------------- physics
    def _advance(self, t: float) -> None:
        """As :meth:`SimVO2._advance`, but stopping (updating the memory curve) at every time where an
        effect's input may turn back (``turning_points``), so that no extremum of the input is missed."""
        if self._turning_effects and t > self._t:
            cuts = sorted({float(c) for e in self._turning_effects for c in e.turning_points(self._t, t)})
            for c in cuts:
                if self._t < c < t:
                    super()._advance(c)
        super()._advance(t)

    def _update_memory(self) -> None:
        if not self._path_effects:
            super()._update_memory()
            return
        x0, v0 = self._x_in, self._v_eq
        rise = self._rise
        m = Moment(self._t, self._v, rise, self.params.ambient_C + rise, self._x_in)
        for e in self.effects:
            rise = e.temperature_rise(rise, m)
        exact = self._settled and rise == self._target
        v_eq = abs(self._v) if exact else self.params.equivalent_voltage(rise)
        x_in = v_eq
        m = Moment(self._t, self._v, rise, self.params.ambient_C + rise)
        for e in self.effects:
            x_in = e.preisach_input(x_in, m)
        if x_in != x0 or v_eq != v0:
            st = self._trial_states()
            p = self.params
            out = []
            for th in np.linspace(0.0, 1.0, self.PATH_SAMPLES + 1)[1:]:
                areas = st.apply(float(self.grid.coordinates(x0 + th * (x_in - x0))))
                out.append(float(areas @ self.density) + p.bias_um + p.thermal_um_per_V * (v0 + th * (v_eq - v0)))
            for e in self._path_effects:
                e.on_path(out)
        self._v_eq, self._x_in, self._beam_rise = v_eq, x_in, rise
        self._states.apply(float(self.grid.coordinates(x_in)))


# ====================================================================== effect base
class Withheld(Effect):
    """An effect of one drawn ``form`` at ``strength``, built for run ``run`` (0 fit, 1 check).

    ``rng`` draws what differs between runs (a drift's realisation);
    ``context`` carries what a run needs to know of the earlier ones
    (``fit_travel_V``: the identification run's total input travel).
    """

    family = ""
    wants_path = False

    def __init__(self, strength: float, form: dict[str, Any], run: int = 0,
                 rng: np.random.Generator | None = None, context: dict[str, float] | None = None) -> None:
        self.form = form
        self.run = run
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.context = dict(context or {})
        self.device: WithheldVO2 | None = None
        self.sim: SimParams | None = None
        self.setup()
        super().__init__(strength)

    def setup(self) -> None:
        """Per-run realisation (called once, before :meth:`reset`)."""

    def bind(self, params: Any) -> None:
        self.sim = params

    def attach(self, device: WithheldVO2) -> None:
        self.device = device

    def state(self) -> dict[str, Any]:
        return {"strength": self.strength, "family": self.family}


# ====================================================================== 1. thermal lag
class ThermalLag(Withheld):
    """Thermal dynamics of one to three modes between the heater and the film.

    A share ``strength`` (0..1) of the beam's temperature goes through the
    slow modes (time constants ``tau_s``, relative weights ``weight``), the
    rest follows at once (the device's own fast lag).  Each mode is driven by
    the heater's voltage (share ``voltage_share``) or by its Joule power; the
    lagged equivalent voltage ``v_lag = a sum w V_k + (1 - a) sqrt(sum w P_k)``
    replaces the voltage, so the memory curve and the thermal term see it.
    """

    name = family = "thermal_lag"

    def setup(self) -> None:
        modes = self.form["modes"]
        self.taus = np.array([m["tau_s"] for m in modes], dtype=float)
        w = np.array([m["weight"] for m in modes], dtype=float)
        self.w = w / w.sum()
        self.a = float(self.form["voltage_share"])

    def reset(self) -> None:
        n = len(self.taus)
        self.t0: float | None = None
        self.yv = np.zeros(n)
        self.yp = np.zeros(n)
        self.v = 0.0

    def _at(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mode states (V, V^2) at time(s) ``t``: shape ``(modes,)`` or ``(len(t), modes)``."""
        if self.t0 is None:
            shape = np.shape(t) + self.yv.shape
            return np.broadcast_to(self.yv, shape), np.broadcast_to(self.yp, shape)
        dt = np.maximum(np.asarray(t, dtype=float) - self.t0, 0.0)
        d = np.exp(-np.multiply.outer(dt, 1.0 / self.taus))
        v = abs(self.v)
        return v + (self.yv - v) * d, v * v + (self.yp - v * v) * d

    def _v_eff(self, v_fast: float | np.ndarray, yv: np.ndarray, yp: np.ndarray) -> float | np.ndarray:
        v_lag = self.a * (yv @ self.w) + (1.0 - self.a) * np.sqrt(np.maximum(yp @ self.w, 0.0))
        s = min(self.strength, 1.0)
        return (1.0 - s) * v_fast + s * v_lag

    def turning_points(self, t_a: float, t_b: float) -> list[float]:
        """Times in ``(t_a, t_b)`` near which the lagged input turns back (the modes, and the device's
        own fast lag, relax from different sides after a reversal), found on a log-spaced time grid."""
        dev = self.device
        if dev is None or self.sim is None or self.t0 is None or t_b - t_a < 1e-3:
            return []
        ts = t_a + np.geomspace(1e-3, t_b - t_a, 400)
        tau = self.sim.time_constant_s
        decay = np.exp(-(ts - t_a) / tau) if tau > 0 else np.zeros_like(ts)
        rise = dev._target + (dev._rise - dev._target) * decay
        v_fast = np.sqrt(np.maximum(rise, 0.0) / self.sim.kelvin_per_V2)
        v = self._v_eff(v_fast, *self._at(ts))
        dv = np.diff(v)
        dv[np.abs(dv) < 1e-13] = 0.0
        sgn = np.sign(dv)
        nz = np.flatnonzero(sgn)
        turns = nz[1:][sgn[nz[1:]] != sgn[nz[:-1]]]
        return [float(ts[i]) for i in turns]

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        self.yv, self.yp = self._at(t_s)
        self.t0, self.v = t_s, new_V

    def temperature_rise(self, rise_K: float, moment: Moment) -> float:
        assert self.sim is not None
        v_eff = float(self._v_eff(self.sim.equivalent_voltage(rise_K), *self._at(moment.t_s)))
        return self.sim.kelvin_per_V2 * v_eff * v_eff


def draw_thermal_lag(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    n = int(rng.integers(1, 4))
    taus = sorted(loguniform(rng, 0.7, 240.0) for _ in range(n))
    weights = rng.dirichlet(np.ones(n))
    drive = rng.random()
    share = 1.0 if drive < 0.3 else 0.0 if drive < 0.6 else float(rng.uniform())
    return {"modes": [{"tau_s": t, "weight": float(w)} for t, w in zip(taus, weights)], "voltage_share": share}


# ====================================================================== 2. creep
CREEP_KERNELS = ("exponential", "multi_exponential", "stretched", "power_law", "logarithmic", "andrade")


def creep_kernel(form: dict[str, Any]) -> Callable[[np.ndarray], np.ndarray]:
    """``Phi(t)``: the fraction of a step's creep reached ``t`` s after it (0 at 0; 1 at infinity or, for
    the unbounded laws, at ``horizon_s``)."""
    kind = form["kernel"]
    tau = float(form["tau_s"])
    if kind == "exponential":
        return lambda t: -np.expm1(-t / tau)
    if kind == "multi_exponential":
        taus = np.array(form["taus_s"])
        ws = np.array(form["weights"])
        return lambda t: (-np.expm1(-np.multiply.outer(t, 1.0 / taus))) @ ws
    if kind == "stretched":
        beta = float(form["beta"])
        return lambda t: -np.expm1(-((t / tau) ** beta))
    if kind == "power_law":
        beta = float(form["beta"])
        return lambda t: 1.0 - (1.0 + t / tau) ** (-beta)
    horizon = float(form["horizon_s"])
    if kind == "logarithmic":
        norm = math.log1p(horizon / tau)
        return lambda t: np.log1p(t / tau) / norm
    beta = float(form["beta"])  # andrade: unbounded power-law creep
    norm = (1.0 + horizon / tau) ** beta - 1.0
    return lambda t: ((1.0 + t / tau) ** beta - 1.0) / norm


class Creep(Withheld):
    """The deflection relaxes after every change of the output.

    The driving quantity is the whole deflection or its phase-transition
    part; a change of it is dated at the set-point that caused it (the first
    reading after the power-on sets the reference).  ``g(d) = d (1 + asym sgn d)
    (|d| / 10 um)^(p - 1)``, ``Phi`` the drawn kernel, ``c = strength * sign``:

    * ``superposition`` (Boltzmann): every change ``d_k`` at ``t_k`` adds
      ``c g(d_k) Phi(t - t_k)``;
    * ``excursion``: after every change the creep moves from where it is
      towards ``c g(E)``, ``E`` the output's excursion since its last
      reversal, along ``Phi`` restarted at the change.
    """

    name = family = "creep"

    def setup(self) -> None:
        self.phi = creep_kernel(self.form)
        self.c = float(self.form["sign"])
        self.p = float(self.form["amplitude_power"])
        self.asym = float(self.form["asymmetry"])
        self.phase_only = self.form["driver"] == "phase"
        self.excursion = self.form.get("memory", "superposition") == "excursion"

    def reset(self) -> None:
        self.t_set = 0.0
        self.last: float | None = None
        self.times: list[float] = []
        self.amps: list[float] = []
        self._arrays = (np.zeros(0), np.zeros(0))
        # excursion memory: output at the last reversal, direction, creep at the last change and its target
        self.anchor = 0.0
        self.dir = 0.0
        self.c0 = self.target = self.t0 = 0.0

    def _g(self, d: float) -> float:
        return d * (1.0 + self.asym * math.copysign(1.0, d)) * (abs(d) / 10.0) ** (self.p - 1.0) if d else 0.0

    def _excursion_value(self, t: float) -> float:
        return self.c0 + (self.target - self.c0) * float(self.phi(np.array(max(t - self.t0, 0.0))))

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        if new_V != old_V:
            self.t_set = t_s

    def deflection(self, um: float, moment: Moment) -> float:
        drive = self.device.phase_um() if (self.phase_only and self.device is not None) else um
        if self.last is None:
            self.last = self.anchor = drive
        d = drive - self.last
        if d != 0.0:
            if self.excursion:
                direction = math.copysign(1.0, d)
                if direction != self.dir:
                    self.anchor, self.dir = self.last, direction
                self.c0, self.t0 = self._excursion_value(self.t_set), self.t_set
                self.target = self._g(drive - self.anchor)
            else:
                self.times.append(self.t_set)
                self.amps.append(self._g(d))
                self._arrays = (np.array(self.times), np.array(self.amps))
            self.last = drive
        if self.excursion:
            return um + self.strength * self.c * self._excursion_value(moment.t_s)
        t, a = self._arrays
        if not t.size:
            return um
        return um + self.strength * self.c * float(a @ self.phi(np.maximum(moment.t_s - t, 0.0)))


def draw_creep(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    kind = pick(rng, CREEP_KERNELS)
    f: dict[str, Any] = {"kernel": kind, "tau_s": loguniform(rng, 2.0, 20_000.0)}
    if kind == "multi_exponential":
        n = int(rng.integers(2, 4))
        f["taus_s"] = sorted(loguniform(rng, 2.0, 20_000.0) for _ in range(n))
        f["weights"] = [float(x) for x in rng.dirichlet(np.ones(n))]
    elif kind == "stretched":
        f["beta"] = float(rng.uniform(0.25, 0.9))
    elif kind == "power_law":
        f["beta"] = float(rng.uniform(0.1, 1.0))
    elif kind == "andrade":
        f["beta"] = float(rng.uniform(0.2, 0.5))
    if kind in ("logarithmic", "andrade"):
        f["horizon_s"] = 3600.0
    f.update(sign=float(rng.choice([-1.0, 1.0])), driver=pick(rng, ("total", "phase")),
             memory="excursion" if rng.random() < 0.35 else "superposition",
             amplitude_power=float(rng.uniform(0.6, 1.6)) if rng.random() < 0.5 else 1.0,
             asymmetry=float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.5 else 0.0)
    return f


# ====================================================================== 3. baseline drift
class BaselineDrift(Withheld):
    """The PSD's zero wanders: ``strength`` um times a slow curve of session time (one realisation per run)."""

    name = family = "baseline_drift"

    def setup(self) -> None:
        self.curve = SlowCurve(self.form["shape"], self.rng)

    def psd(self, volts: float, moment: Moment) -> float:
        assert self.sim is not None
        return volts + self.strength * self.curve(moment.t_s) / self.sim.psd_um_per_V


def draw_slow(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    return {"shape": draw_slow_shape(rng)}


# ====================================================================== 4. ambient drift
class AmbientDrift(Withheld):
    """The room drifts by ``dT = strength * f(t)`` K: the beam's temperature, seen by the hysterons.

    The Preisach input becomes the equivalent voltage of ``rise (1 + gamma dT) + dT``
    (``gamma``: the package's thermal resistance changing with temperature);
    the thermal term of equation (22) keeps following the heater.
    """

    name = family = "ambient_drift"
    max_step_s = 5.0

    def setup(self) -> None:
        self.curve = SlowCurve(self.form["shape"], self.rng)
        self.gamma = float(self.form["gamma_per_K"])

    def preisach_input(self, volts: float, moment: Moment) -> float:
        assert self.sim is not None
        dT = self.strength * self.curve(moment.t_s)
        rise = self.sim.kelvin_per_V2 * volts * volts
        return self.sim.equivalent_voltage(rise * (1.0 + self.gamma * dT) + dT)


def draw_ambient(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    gamma = float(rng.uniform(-0.004, 0.004)) if rng.random() < 0.5 else 0.0
    return {"shape": draw_slow_shape(rng), "gamma_per_K": gamma}


# ====================================================================== 5. joule power
JOULE_SHAPES = ("power", "alpha_of_T", "power_law", "saturating")


class JoulePower(Withheld):
    """Thermal expansion that follows the beam's temperature rise ``r`` (~ v^2), not the voltage:
    ``u += strength * sign * phi(r / r_max)``."""

    name = family = "joule_power"

    def setup(self) -> None:
        f = self.form
        kind = f["shape"]
        if kind == "power":
            self.phi = lambda r: r
        elif kind == "alpha_of_T":
            g = float(f["gamma"])
            self.phi = lambda r: (r + g * r * r) / (1.0 + abs(g))
        elif kind == "power_law":
            q = float(f["exponent"])
            self.phi = lambda r: r ** q
        else:
            r0 = float(f["r0"])
            self.phi = lambda r: -math.expm1(-r / r0) / -math.expm1(-1.0 / r0)
        self.sign = float(f["sign"])

    def deflection(self, um: float, moment: Moment) -> float:
        assert self.sim is not None
        r_max = self.sim.steady_rise_K(self.sim.v_max_V)
        return um + self.strength * self.sign * self.phi(max(moment.rise_K, 0.0) / r_max)


def draw_joule(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    kind = pick(rng, JOULE_SHAPES)
    f: dict[str, Any] = {"shape": kind}
    if kind == "alpha_of_T":
        f["gamma"] = float(rng.uniform(-0.6, 1.5))
    elif kind == "power_law":
        f["exponent"] = float(rng.uniform(0.6, 1.8))
    elif kind == "saturating":
        f["r0"] = float(rng.uniform(0.3, 2.0))
    same = rng.random() < 0.7  # usually the same direction as the linear thermal term
    f["sign"] = float(np.sign(base.thermal_um_per_V) or -1.0) * (1.0 if same else -1.0)
    return f


# ====================================================================== 6. sensor nonlinearity
SENSOR_SHAPES = ("tanh", "arctan", "soft_clip", "expanding", "polynomial", "asymmetric", "random_monotone")


def sensor_map(form: dict[str, Any]) -> Callable[[float], float]:
    """``H(z)``, monotone increasing with ``H'(0)`` about 1, on the normalised reading ``z``."""
    kind = form["shape"]
    c = float(form.get("c", 1.0))
    if kind == "tanh":
        return lambda z: math.tanh(c * z) / c
    if kind == "arctan":
        return lambda z: math.atan(c * z) / c
    if kind == "soft_clip":
        p = float(form["p"])
        return lambda z: z / (1.0 + abs(c * z) ** p) ** (1.0 / p)
    if kind == "expanding":
        return lambda z: math.sinh(c * z) / c
    if kind == "polynomial":
        a2, a3 = float(form["a2"]), float(form["a3"])
        return lambda z: z + a2 * z * z + a3 * z ** 3
    if kind == "asymmetric":
        a, w = float(form["a"]), float(form["w"])
        return lambda z: z + a * w * (abs(z / w) + math.log1p(math.exp(-2 * abs(z / w))) - math.log(2.0))
    # random_monotone: the integral of exp(g), g a smooth random function
    g = RandomSmooth(np.random.default_rng(int(form["seed"])), float(form["length"]), "squared_exponential")
    zs = np.linspace(-4.0, 4.0, 801)
    dens = np.exp(float(form["amplitude"]) * (g(zs) - g(0.0)))
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(zs))])
    cum -= np.interp(0.0, zs, cum)
    lo_slope, hi_slope = dens[0], dens[-1]

    def h(z: float) -> float:
        if z < zs[0]:
            return float(cum[0] + lo_slope * (z - zs[0]))
        if z > zs[-1]:
            return float(cum[-1] + hi_slope * (z - zs[-1]))
        return float(np.interp(z, zs, cum))

    return h


class SensorNonlinearity(Withheld):
    """The PSD reads ``(Z / s) [H(s psd / Z - c) - H(-c)]`` of the true reading ``psd`` (V), ``Z = 5 V``:
    ``s = strength`` is how far the spot's travel reaches into the detector's nonlinear range (0: linear),
    ``c`` the optical centre's offset, ``H`` the drawn monotone shape."""

    name = family = "sensor_nonlinearity"
    SCALE_V = 5.0

    def setup(self) -> None:
        self.h = sensor_map(self.form)
        self.centre = float(self.form["centre"])
        self.h0 = self.h(-self.centre)

    def psd(self, volts: float, moment: Moment) -> float:
        s, z = self.strength, self.SCALE_V
        return z / s * (self.h(s * volts / z - self.centre) - self.h0)


def draw_sensor(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    kind = pick(rng, SENSOR_SHAPES)
    f: dict[str, Any] = {"shape": kind, "centre": float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.5 else 0.0}
    if kind in ("tanh", "arctan"):
        f["c"] = float(rng.uniform(0.3, 1.5))
    elif kind == "soft_clip":
        f.update(c=float(rng.uniform(0.3, 1.2)), p=float(rng.uniform(1.5, 4.0)))
    elif kind == "expanding":
        f["c"] = float(rng.uniform(0.2, 0.8))
    elif kind == "polynomial":
        while True:  # monotone over |z| <= 2.5
            a2, a3 = float(rng.uniform(-0.2, 0.2)), float(rng.uniform(-0.05, 0.1))
            zz = np.linspace(-2.5, 2.5, 201)
            if np.all(1 + 2 * a2 * zz + 3 * a3 * zz * zz > 0.2):
                break
        f.update(a2=a2, a3=a3)
    elif kind == "asymmetric":
        f.update(a=float(rng.uniform(-0.6, 0.6)), w=float(rng.uniform(0.3, 2.0)))
    else:
        f.update(seed=int(rng.integers(2**31)), length=float(rng.uniform(0.5, 3.0)),
                 amplitude=float(rng.uniform(0.15, 0.5)))
    return f


# ====================================================================== 7. reversible
REVERSIBLE_SHAPES = ("sigmoid", "bump", "langevin", "softplus", "polynomial", "random_smooth")


def reversible_shape(form: dict[str, Any]) -> Callable[[float], float]:
    """``R(xi)`` on ``xi`` in [0, 1], of order one."""
    kind = form["shape"]
    x0, w = float(form.get("centre", 0.5)), float(form.get("width", 0.1))
    if kind == "sigmoid":
        return lambda xi: math.tanh((xi - x0) / w)
    if kind == "bump":
        return lambda xi: math.exp(-0.5 * ((xi - x0) / w) ** 2)
    if kind == "langevin":
        def lang(xi: float) -> float:
            y = (xi - x0) / w
            return y / 3.0 - y ** 3 / 45.0 if abs(y) < 1e-3 else 1.0 / math.tanh(y) - 1.0 / y
        return lang
    if kind == "softplus":
        top = w * math.log1p(math.exp((1.0 - x0) / w))
        return lambda xi: w * math.log1p(math.exp((xi - x0) / w)) / top
    if kind == "polynomial":
        coef = np.asarray(form["legendre"], dtype=float)
        return lambda xi: float(np.polynomial.legendre.legval(2 * xi - 1, coef))
    g = RandomSmooth(np.random.default_rng(int(form["seed"])), float(form["length"]), pick(
        np.random.default_rng(int(form["seed"]) + 1), ("squared_exponential", "matern52")))
    return lambda xi: g(xi)


class Reversible(Withheld):
    """An anhysteretic deflection ``strength * sign * R(xi)``, ``xi`` the input (``v / v_max``) or the
    temperature rise (``r / r_max``)."""

    name = family = "reversible"

    def setup(self) -> None:
        self.r = reversible_shape(self.form)
        self.sign = float(self.form["sign"])
        self.on_temperature = self.form["argument"] == "temperature"

    def deflection(self, um: float, moment: Moment) -> float:
        assert self.sim is not None and self.device is not None
        if self.on_temperature:
            xi = max(moment.rise_K, 0.0) / self.sim.steady_rise_K(self.sim.v_max_V)
        else:
            xi = self.device._v_eq / self.sim.v_max_V
        return um + self.strength * self.sign * self.r(xi)


def draw_reversible(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    kind = pick(rng, REVERSIBLE_SHAPES)
    f: dict[str, Any] = {"shape": kind, "sign": float(rng.choice([-1.0, 1.0])),
                         "argument": pick(rng, ("voltage", "temperature"))}
    if kind in ("sigmoid", "bump", "langevin", "softplus"):
        f.update(centre=float(rng.uniform(0.15, 0.95)), width=loguniform(rng, 0.03, 0.3))
    elif kind == "polynomial":
        deg = int(rng.integers(3, 6))
        f["legendre"] = [0.0, 0.0] + [float(rng.standard_normal() / k) for k in range(2, deg + 1)]
    else:
        f.update(seed=int(rng.integers(2**31)), length=float(rng.uniform(0.08, 0.4)))
    return f


# ====================================================================== 8. interaction
class Interaction(Withheld):
    """Mean-field coupling: the hysterons see ``x = v + sign * strength * u(x) / A`` (volts), or the
    equivalent voltage of ``r(v) + sign * strength * u(x) / A`` (kelvin), ``u`` the phase-transition
    deflection, ``A`` its half swing; solved self-consistently at every device event, the memory curve
    moved monotonically from its previous state (exact between events)."""

    name = family = "interaction"

    def setup(self) -> None:
        self.sign = float(self.form["sign"])
        self.on_temperature = self.form["domain"] == "temperature"

    def _target(self, volts: float, phase: float) -> float:
        assert self.sim is not None and self.device is not None
        f = self.sign * self.strength * phase / self.device.amplitude_um
        if self.on_temperature:
            return self.sim.equivalent_voltage(self.sim.kelvin_per_V2 * volts * volts + f)
        return volts + f

    def preisach_input(self, volts: float, moment: Moment) -> float:
        dev = self.device
        assert dev is not None
        lo = self._target(volts, -dev.amplitude_um)
        hi = self._target(volts, dev.amplitude_um)
        lo, hi = min(lo, hi), max(lo, hi)
        if hi - lo < 1e-15:
            return lo

        def g(x: float) -> float:
            return x - self._target(volts, dev.phase_after(x))

        glo, ghi = g(lo), g(hi)
        if glo == 0.0:
            return lo
        if ghi == 0.0:
            return hi
        if glo > 0 or ghi < 0:  # cannot happen for a consistent bracket; keep the open-loop input
            return volts
        return float(brentq(g, lo, hi, xtol=1e-13, rtol=4 * np.finfo(float).eps, maxiter=200))


def interaction_bound(params: SimParams, form: dict[str, Any], loop_gain: float = 0.5) -> float:
    """The largest coupling (V or K) whose loop gain ``|k| d(u/A)/dx`` stays below ``loop_gain`` on the
    major loop's branches: beyond, the self-consistent input would jump (an avalanche), not hysteresis."""
    dev = SimVO2(dataclasses.replace(params, effects={}))
    g = dev.grid
    phase = PreisachModel(g, dev.density, mu0=0.0, c_d=0.0)
    amp = float(np.abs(dev.density).sum())
    xs = np.linspace(g.v_min, g.v_max, 40 * g.levels + 1)
    ascending = phase.predict(xs)
    descending = phase.predict(np.concatenate([[g.v_max], xs[::-1]]))[1:][::-1]
    axis = params.kelvin_per_V2 * xs**2 if form["domain"] == "temperature" else xs
    slope = max(float(np.max(np.abs(np.diff(b / amp) / np.diff(axis)))) for b in (ascending, descending))
    return loop_gain / slope


def draw_interaction(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    return {"sign": float(rng.choice([-1.0, 1.0])), "domain": pick(rng, ("voltage", "temperature"))}


# ====================================================================== 9. first point
class FirstPoint(Withheld):
    """The set-point that reverses the input's direction reads ``delta`` more, the following ones
    ``delta r^(m-1)`` (``m``: set-points since the reversal; repeats of a set-point do not count), until
    the next reversal; ``delta = strength * G(step)``, from the drawn sign rule and size law."""

    name = family = "first_point"

    def reset(self) -> None:
        self.dir = 0.0
        self.m = 0
        self.delta = 0.0

    def _size(self, step: float) -> float:
        f = self.form
        d = math.copysign(1.0, step)
        law = f["size_law"]
        mag = 1.0 if law == "constant" else abs(step) if law == "linear" else math.tanh(abs(step) / f["scale_V"])
        sgn = {"along": d, "against": -d, "fixed": 1.0}[f["sign_rule"]] * f["sign"]
        return sgn * mag * (1.0 + f["asymmetry"] * d)

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        step = new_V - old_V
        if step == 0.0:
            return
        d = math.copysign(1.0, step)
        if self.dir != 0.0 and d != self.dir:
            self.m, self.delta = 1, self._size(step)
        elif self.m:
            self.m += 1
        self.dir = d

    def deflection(self, um: float, moment: Moment) -> float:
        if not self.m:
            return um
        return um + self.strength * self.delta * float(self.form["persistence"]) ** (self.m - 1)


def draw_first_point(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    return {"sign_rule": pick(rng, ("along", "against", "fixed")), "sign": float(rng.choice([-1.0, 1.0])),
            "size_law": pick(rng, ("constant", "linear", "saturating")), "scale_V": loguniform(rng, 0.05, 1.0),
            "asymmetry": float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.5 else 0.0,
            "persistence": float(rng.uniform(0.0, 0.35)) if rng.random() < 0.5 else 0.0}


# ====================================================================== outside: backlash
class Backlash(Withheld):
    """Play in the optical lever's mount: a second, rate-independent hysteresis on the deflection.

    The mount follows the beam only once the beam has taken up the play
    (half width ``strength`` um, ``(1 +- asym)`` up/down); a share ``elastic``
    of the motion passes through the play regardless.  Evaluated along the
    whole path of the deflection between device events.
    """

    name = family = "backlash"
    wants_path = True

    def reset(self) -> None:
        self.pos: float | None = None

    def _take(self, u: float) -> None:
        up, down = self.strength * (1.0 + self.form["asymmetry"]), self.strength * (1.0 - self.form["asymmetry"])
        self.pos = u if self.pos is None else min(max(self.pos, u - up), u + down)

    def on_path(self, outputs: list[float]) -> None:
        for u in outputs:
            self._take(u)

    def deflection(self, um: float, moment: Moment) -> float:
        self._take(um)
        assert self.pos is not None
        e = float(self.form["elastic"])
        return (1.0 - e) * self.pos + e * um


def draw_backlash(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    return {"asymmetry": float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.5 else 0.0,
            "elastic": float(rng.uniform(0.0, 0.5)) if rng.random() < 0.5 else 0.0}


# ====================================================================== outside: accommodation
class Accommodation(Withheld):
    """The loop changes with use: the phase-transition weights scale by ``1 - strength * sign * F(n)``,
    ``n`` the cycles since power-on (``training``) or over the device's life (``fatigue``: the check
    run starts where the identification run ended), counted as input travel over two full ranges;
    ``F`` saturating, logarithmic or a power of ``n``; optionally only the cells of high (or low)
    switching thresholds."""

    name = family = "accommodation"

    def setup(self) -> None:
        f = self.form
        self.n0 = float(f["n0"])
        self.sign = float(f["sign"])
        self.start = float(self.context.get("fit_travel_V", 0.0)) if (f["memory"] == "fatigue" and self.run) else 0.0

    def attach(self, device: WithheldVO2) -> None:
        super().attach(device)
        g = device.grid
        alpha = g.v_min + (g.cell_alpha + 0.5) * g.step
        beta = g.v_min + (g.cell_beta + 0.5) * g.step
        where = self.form["cells"]
        mid = float(self.form["split_V"])
        if where == "all":
            w = np.ones_like(alpha)
        elif where == "high":
            w = 1.0 / (1.0 + np.exp(-(0.5 * (alpha + beta) - mid) / 0.3))
        else:
            w = 1.0 / (1.0 + np.exp((0.5 * (alpha + beta) - mid) / 0.3))
        self.weights = device.density * w

    def reset(self) -> None:
        self.travel = self.start
        self.v = 0.0

    def on_setpoint(self, t_s: float, old_V: float, new_V: float) -> None:
        self.travel += abs(new_V - old_V)

    def _f(self, n: float) -> float:
        law, n0 = self.form["law"], self.n0
        if law == "saturating":
            return -math.expm1(-n / n0)
        if law == "logarithmic":
            return math.log1p(n / n0) / math.log1p(50.0 / n0)
        return (n / n0) ** self.form["beta"] / (50.0 / n0) ** self.form["beta"]

    def deflection(self, um: float, moment: Moment) -> float:
        assert self.device is not None and self.sim is not None
        n = self.travel / (2.0 * (self.sim.v_max_V - self.sim.v_min_V))
        part = float(self.device._states.areas @ self.weights)
        return um - self.strength * self.sign * self._f(n) * part


def draw_accommodation(rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    f: dict[str, Any] = {"law": pick(rng, ("saturating", "logarithmic", "power")), "n0": loguniform(rng, 3.0, 100.0),
                         "sign": float(rng.choice([-1.0, 1.0], p=[0.3, 0.7])),
                         "memory": pick(rng, ("training", "fatigue")),
                         "cells": pick(rng, ("all", "all", "high", "low")),
                         "split_V": float(rng.uniform(2.5, 4.5))}
    if f["law"] == "power":
        f["beta"] = float(rng.uniform(0.3, 1.0))
    return f


# ====================================================================== outside: gain drift
class GainDrift(Withheld):
    """The PSD's sensitivity drifts: ``psd -> offset + (psd - offset)(1 + strength * f(t))``."""

    name = family = "gain_drift"

    def setup(self) -> None:
        self.curve = SlowCurve(self.form["shape"], self.rng)

    def psd(self, volts: float, moment: Moment) -> float:
        assert self.sim is not None
        off = self.sim.psd_offset_V
        return off + (volts - off) * (1.0 + self.strength * self.curve(moment.t_s))


# ====================================================================== registry
@dataclass(frozen=True)
class Family:
    """One mechanism: how to draw a form, the effect that realises it, and its strength's range.

    ``guess`` is a strength to start the calibration from; ``max_strength``
    the physical bound (None: none); ``unit`` the strength's unit.
    """

    name: str
    draw: Callable[[np.random.Generator, SimParams], dict[str, Any]]
    effect: type[Withheld]
    guess: float
    unit: str
    max_strength: float | None = None
    in_library: bool = True


FAMILIES: dict[str, Family] = {f.name: f for f in [
    Family("thermal_lag", draw_thermal_lag, ThermalLag, 0.01, "share of the heat through the slow modes", 1.0),
    Family("creep", draw_creep, Creep, 0.002, "creep per unit output change"),
    Family("baseline_drift", draw_slow, BaselineDrift, 0.02, "um"),
    Family("ambient_drift", draw_ambient, AmbientDrift, 0.05, "K", 30.0),
    Family("joule_power", draw_joule, JoulePower, 0.2, "um"),
    Family("sensor_nonlinearity", draw_sensor, SensorNonlinearity, 0.1, "spot travel / detector range", 2.0),
    Family("reversible", draw_reversible, Reversible, 0.2, "um"),
    # its bound depends on the device: generate.calibrate uses interaction_bound
    Family("interaction", draw_interaction, Interaction, 0.005, "V or K at the full phase swing"),
    Family("first_point", draw_first_point, FirstPoint, 0.02, "um"),
    Family("backlash", draw_backlash, Backlash, 0.01, "um", 5.0, False),
    Family("accommodation", draw_accommodation, Accommodation, 0.002, "relative", 0.5, False),
    Family("gain_drift", draw_slow, GainDrift, 0.001, "relative", 0.2, False),
]}
assert tuple(FAMILIES) == LIBRARY + OUTSIDE


def draw_form(name: str, rng: np.random.Generator, base: SimParams) -> dict[str, Any]:
    """A form of family ``name`` drawn from ``rng`` (JSON-safe)."""
    return FAMILIES[name].draw(rng, base)


def make_effect(name: str, strength: float, form: dict[str, Any], run: int, rng: np.random.Generator,
                context: dict[str, float] | None = None) -> Withheld:
    """The effect of family ``name`` with ``form`` at ``strength`` for run ``run``."""
    return FAMILIES[name].effect(strength, form, run, rng, context)


def make_device(params: SimParams, effects: list[Withheld], clock: Any = None) -> WithheldVO2:
    """The device with ``effects`` in pipeline order (:data:`ORDER`)."""
    ordered = sorted(effects, key=lambda e: ORDER.index(e.family))
    return WithheldVO2(params, clock, effects=ordered)
