"""Simulate a session of runs on a device with unmodelled mechanisms.

Physical order of every reading (a mechanism absent leaves its stage the identity):

  heater power  -> thermal_lag (slow thermal paths) -> + ambient_drift  = film temperature
  film          -> interaction (mean field, self-consistent) -> Preisach (+ accommodation)
  deflection    =  bias + thermal term (joule_power) + phase + reversible
               -> creep (relaxation after every change) -> backlash (optical-lever mount)
  sensor        -> spillover_fringes -> sensor_nonlinearity -> gain_drift -> baseline_drift
               -> first_point -> noise

Between two runs the heater is off for about ten minutes: that pause is
simulated as a set-point at 0 V without a reading, so every state (slow
thermal paths, creep, the mount's play, the film's cycle count) carries over
physically.  See README.md for the forms and the logger.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import brentq

from ..base import BaseDevice
from .context import DeviceContext, cell_layout, context
from .forms import LIBRARY, OUTSIDE
from .paths import DriftPath, stream, tag

#: ADC sampling period of one PSD reading in a burst (s).
SAMPLE_PERIOD_S = 0.005
#: Sub-sampling of a dwell to follow the film's temperature path (fractions of the dwell).
_GRID = np.concatenate([[0.0], np.geomspace(2e-3, 1.0, 20)])

_TAG_TIME = tag("timing")
_TAG_NOISE = tag("noise")


# =========================================================================== timing

def run_timing(seed: int, run_index: int, dwell: np.ndarray, readings: int):
    """The run's clock, from a stream of its own: (pause before the run, set-point times, reading times, logged dwell)."""
    rng = stream(seed, run_index, _TAG_TIME)
    gap = float(rng.uniform(540.0, 720.0))  # heater off between runs, "about ten minutes"
    n = dwell.size
    start = float(rng.uniform(0.5, 2.0))  # script start-up before the first set-point
    latency = rng.uniform(0.0, 0.015, n) + rng.exponential(0.02, n)  # OS timer / DAQ write
    overhead = 0.04 + rng.exponential(0.06, n)  # logging, file write, next command
    burst = readings * SAMPLE_PERIOD_S
    held = dwell + latency
    seg = held + burst + overhead
    T = start + np.concatenate([[0.0], np.cumsum(seg[:-1])])
    t = T + held + 0.5 * burst
    return gap, T, t, held + 0.5 * burst


# =========================================================================== film

class _Accommodation:
    """Cell weights that change with the cycles the film has gone through."""

    _SHIFTS = {  # (da, db): the weight now at (a, b) comes from (a - da, b - db)
        "shift": (1, 1), "width": (1, -1), "heating_branch": (1, 0), "cooling_branch": (0, 1),
    }

    def __init__(self, form: dict, strength: float, device: BaseDevice, ctx: DeviceContext):
        layout = cell_layout(device)
        L = device.levels
        M = np.zeros((L, L))
        ok = layout >= 0
        M[ok] = device.density_um[layout[ok]]
        D = np.zeros((L, L))
        for p in form["patterns"]:
            name, s, w = p["pattern"], p["sign"], p["weight"]
            if name == "fatigue":  # sign < 0: the film loses transformable volume
                D += w * s * M
                continue
            da, db = self._SHIFTS[name]
            da, db = s * da, s * db
            S = np.zeros((L, L))
            for a in range(L):
                for b in range(a + 1):
                    a0, b0 = int(a - da), int(b - db)
                    if 0 <= b0 <= a0 < L:
                        S[a, b] = M[a0, b0]
            D += w * (S - M)
        delta = np.zeros(device.density_um.size)
        delta[layout[ok]] = D[ok]
        loop = ctx.major_loop(dataclasses.replace(device, density_um=delta))
        scale = float(np.max(np.abs(loop)))
        if scale <= 0:
            delta = -device.density_um.copy()
            scale = float(np.max(np.abs(ctx.major_phase)))
        self.delta_device = dataclasses.replace(device, density_um=delta * ctx.swing_um / scale)
        self.amp = strength * form["swing_fraction"]
        self.law = form["law"]
        self.c0 = form.get("cycles_scale", 10.0)
        self.p = form.get("exponent", 1.0)
        self.n0 = form["prior_cycles"]
        self.norm = self._F(20.0 + self.n0) - self._F(self.n0)

    def _F(self, c: float) -> float:
        if self.law == "saturating":
            return 1.0 - math.exp(-c / self.c0)
        if self.law == "log":
            return math.log1p(c / self.c0)
        if self.law == "power":
            return (c / 20.0) ** self.p
        return c / 20.0

    def factor(self, cycles: float) -> float:
        return self.amp * (self._F(cycles + self.n0) - self._F(self.n0)) / self.norm


class _Film:
    """The Preisach film, with the mean-field interaction and accommodation when present."""

    def __init__(self, device: BaseDevice, ctx: DeviceContext, inter, acc: _Accommodation | None):
        self.device, self.ctx, self.acc = device, ctx, acc
        self.sw = device.phase_swing_um
        self.coupling = None
        if inter is not None:
            form, s = inter
            c = form["sign"] * s * form["loop_gain_per_strength"] / max(ctx.phase_slope_max, 1e-9)
            q = form.get("cubic", 0.0) if form["shape"] == "cubic" else 0.0
            self.coupling = (c, q)
        self.cycles = 0.0
        self._fresh()

    def _fresh(self):
        self.h = self.device.hysteresis()
        self.hd = self.acc.delta_device.hysteresis() if self.acc else None
        self.pb = self.h.value()
        self.pd = self.hd.value() if self.hd else 0.0

    def _total(self, pb, pd, cycles):
        if self.acc is None:
            return pb
        return pb + self.acc.factor(cycles) * pd

    def _field(self, p: float) -> float:
        c, q = self.coupling
        z = p / self.sw
        return c * self.sw * (z + q * z ** 3) / (1.0 + q)

    def _peek(self, xe: float) -> float:
        pb = self.h.peek(xe)
        pd = self.hd.peek(xe) if self.hd else 0.0
        return self._total(pb, pd, self.cycles + abs(pb - self.pb) / (4 * self.sw))

    def value(self) -> float:
        return self._total(self.pb, self.pd, self.cycles)

    def _solve(self, x: float) -> float:
        """The self-consistent phase p = H(x + field(p)): secant from the present state, bracketing as a fallback."""
        g = lambda p: self._peek(x + self._field(p)) - p  # noqa: E731 (decreasing in p)
        tol = 1e-10 * self.sw
        p0 = self.value()
        g0 = g(p0)
        if abs(g0) <= tol:
            return p0
        p1 = p0 + g0
        g1 = g(p1)
        for _ in range(12):
            if abs(g1) <= tol:
                return p1
            if g1 == g0:
                break
            p0, g0, p1 = p1, g1, p1 - g1 * (p1 - p0) / (g1 - g0)
            g1 = g(p1)
        lim = 2.0 * self.sw * (1.0 + (abs(self.acc.amp) * 4 if self.acc else 0.0)) + 1.0
        return brentq(g, -lim, lim, xtol=tol, rtol=1e-12)

    def move(self, x: float, reset_if_cold: bool = False) -> float:
        """Move the film's input to ``x`` (V, equivalent) and return the phase part (um)."""
        if self.coupling is not None:
            p = self._solve(x)
            xe = x + self._field(p)
        else:
            xe = x
        pb = self.h.move(xe)
        if self.hd is not None:
            self.pd = self.hd.move(xe)
        if reset_if_cold and xe <= self.device.v_min_V:
            # every grain insulating: negative saturation, whatever the history
            self.h = self.device.hysteresis()
            pb = self.h.value()
            if self.hd is not None:
                self.hd = self.acc.delta_device.hysteresis()
                self.pd = self.hd.value()
        self.cycles += abs(pb - self.pb) / (4 * self.sw)
        self.pb = pb
        return self.value()


# =========================================================================== thermal

class _ThermalLag:
    """Slow thermal paths, power driven: P_eff = P + A sum_i a_i (P_i - P), dP_i/dt = (P - P_i)/tau_i."""

    def __init__(self, form: dict, strength: float):
        self.tau = np.array(form["taus_s"], dtype=float)
        w = np.array(form["weights"], dtype=float)
        # the form's fraction is what is still missing (or in excess) 20 s after a step
        seen = max(float(np.sum(np.abs(w) * np.exp(-20.0 / self.tau))), 0.15)
        self.a = w * strength * form["fraction_per_strength"] / seen
        self.Pi = np.zeros(self.tau.size)  # long at 0 V
        self.P = 0.0
        self.t = -np.inf

    def step(self, T: float, P: float):
        if np.isfinite(self.t):
            self.Pi = self.P + (self.Pi - self.P) * np.exp(-(T - self.t) / self.tau)
        self.P, self.t = P, T

    def power(self, offsets: np.ndarray) -> np.ndarray:
        """Effective power (V^2) at ``offsets`` (s) after the last set-point."""
        Pi = self.P + (self.Pi[None, :] - self.P) * np.exp(-offsets[:, None] / self.tau[None, :])
        return self.P + (Pi - self.P) @ self.a


# =========================================================================== deflection

class _Joule:
    def __init__(self, form: dict, strength: float, device: BaseDevice, ctx: DeviceContext):
        vmax = device.v_max_V
        beta = form["alpha_change"]
        self.vmax, self.beta = vmax, beta
        grid = np.linspace(0.0, vmax, 241)
        g = self._g(grid)
        anchor = form["anchor"]
        if anchor == "end":
            k = vmax / self._g(np.array([vmax]))[0]
        elif anchor == "transition":
            k = ctx.v_mid / self._g(np.array([ctx.v_mid]))[0]
        else:
            k = float(np.sum(grid * g) / np.sum(g * g))
        self.k = k
        dev = float(np.max(np.abs(k * g - grid)))
        c = device.thermal_um_per_V
        self.c = c
        self.m = strength * form["swing_fraction"] * ctx.swing_um / max(abs(c) * dev, 1e-12)

    def _g(self, v):
        z = (np.asarray(v) / self.vmax) ** 2  # temperature rise / its value at v_max
        return z + 0.5 * self.beta * z * z

    def extra(self, v_th: float) -> float:
        return self.c * self.m * (self.k * float(self._g(v_th)) - v_th)


class _Reversible:
    def __init__(self, form: dict, strength: float, device: BaseDevice, ctx: DeviceContext):
        self.form = form
        self.A = form["sign"] * strength * form["swing_fraction"] * ctx.swing_um
        self.vmax = device.v_max_V
        self.centre = ctx.v_mid + form.get("centre_offset_V", 0.0)
        self.use_temperature = form["input"] == "temperature"

    def __call__(self, x: float) -> float:
        f = self.form
        s = f["shape"]
        if s == "sigmoid":
            r = math.tanh((x - self.centre) / f["width_V"])
        elif s == "bump":
            r = math.exp(-0.5 * ((x - self.centre) / f["width_V"]) ** 2)
        elif s == "power":
            r = (max(x, 0.0) / self.vmax) ** f["exponent"]
        else:
            r = 1.0 - math.exp(-max(x, 0.0) / f["scale_V"])
        return self.A * r


class _Creep:
    def __init__(self, form: dict, strength: float, ctx: DeviceContext):
        self.tau = np.array(form["taus_s"], dtype=float)
        self.w = np.array(form["weights"], dtype=float)
        # the form's fraction is the share of a change still to come 20 s after it
        seen = max(float(np.sum(self.w * np.exp(-20.0 / self.tau))), 0.2)
        self.a = strength * form["fraction_per_strength"] / seen
        self.sign = 1.0 if form["direction"] == "forward" else -1.0
        self.law = form["law"]
        self.ref = 0.25 * ctx.swing_um
        self.p = form.get("exponent", 1.0)
        self.u0 = form.get("saturation_swing_fraction", 0.2) * ctx.swing_um
        self.up, self.down = form["up_factor"], form["down_factor"]
        self.use_phase = form["source"] == "phase"
        self.S = np.zeros(self.tau.size)
        self.t = None
        self.prev = None

    def _h(self, d: float) -> float:
        if self.law == "power":
            r = math.copysign(abs(d) ** self.p * self.ref ** (1.0 - self.p), d)
        elif self.law == "saturating":
            r = d / (1.0 + abs(d) / self.u0)
        else:
            r = d
        return r * (self.up if d > 0 else self.down)

    def rest(self, src: float):
        self.prev = src

    def apply(self, T: float, t: float, src: float, u: float) -> float:
        if self.t is not None:
            self.S = self.S * np.exp(-(T - self.t) / self.tau)
        self.t = T
        self.S = self.S + self.w * self._h(src - self.prev)
        self.prev = src
        residual = float(np.sum(self.S * np.exp(-(t - T) / self.tau)))
        return u - self.sign * self.a * residual


class _Mount:
    """Play in the optical lever's mount: rate-independent, acting on the deflection."""

    def __init__(self, form: dict, strength: float, ctx: DeviceContext):
        r = strength * form["half_width_swing_fraction"] * ctx.swing_um
        al = form["asymmetry"]
        self.kind = form["kind"]
        if self.kind == "distributed":
            q = np.linspace(0.25, 2.0, 8)
            w = {"uniform": np.ones_like(q), "triangular": 2.25 - q,
                 "exponential": np.exp(-q)}[form["profile"]]
            self.w = w / w.sum()
            self.r = r * q / float(self.w @ q)  # mean half-width r
        else:
            self.w = np.ones(1)
            self.r = np.array([r])
        self.ru, self.rd = self.r * (1.0 + al), self.r * (1.0 - al)
        self.keep = form.get("slip_keep", 0.0)
        self.y = None

    def rest(self, u: float):  # the beam came down to rest: the mount sits above it
        if self.kind == "stick_slip":
            self.y = np.array([u + self.keep * self.rd[0]])
        else:
            self.y = u + self.rd

    def apply(self, u: float) -> float:
        if self.kind == "stick_slip":
            y = self.y[0]
            if u - y > self.ru[0]:
                y = u - self.keep * self.ru[0]
            elif y - u > self.rd[0]:
                y = u + self.keep * self.rd[0]
            self.y = np.array([y])
        else:
            self.y = np.minimum(np.maximum(self.y, u - self.ru), u + self.rd)
        return float(self.w @ self.y)


# =========================================================================== sensor

def _nl_shape(form: dict):
    s = form["shape"]
    if s == "tanh":
        return np.tanh
    if s == "arctan":
        return np.arctan
    if s == "algebraic":
        return lambda z: z / np.sqrt(1.0 + z * z)
    if s == "asym_tanh":
        a, b = form["scale_pos"], form["scale_neg"]
        return lambda z: np.where(z >= 0, np.tanh(a * z) / a, np.tanh(b * z) / b)
    q = form["q"]

    def one_sided(z):  # compresses exponentially on one side, stretches gently (C2) on the other
        w = q * np.asarray(z, dtype=float)
        return np.where(w >= 0, -np.expm1(-np.maximum(w, 0.0)), w - 0.5 * w * w) / q

    return one_sided


class _SensorNL:
    def __init__(self, form: dict, strength: float, ctx: DeviceContext):
        f = _nl_shape(form)
        half = 0.5 * ctx.swing_um
        c = 0.5 * (ctx.u_lo + ctx.u_hi) + form["centre_offset"] * half
        u = np.linspace(ctx.u_lo, ctx.u_hi, 201)
        target = form["swing_fraction"] * ctx.swing_um

        def dev(logL):
            L = math.exp(logL)
            with np.errstate(over="ignore", invalid="ignore"):
                e = np.abs(c + L * f((u - c) / L) - u)
            e = np.where(np.isfinite(e), e, 1e300)
            return float(np.max(e)) - target

        lo, hi = math.log(1e-3 * half), math.log(1e4 * half)
        L1 = math.exp(brentq(dev, lo, hi, xtol=1e-6))
        self.f, self.c, self.L = f, c, L1 / strength

    def __call__(self, y: np.ndarray) -> np.ndarray:
        return self.c + self.L * self.f((y - self.c) / self.L)


class _Fringes:
    """Interference of light spilling past the beam with light from the beam (see README)."""

    def __init__(self, form: dict, strength: float, device: BaseDevice, ctx: DeviceContext):
        self.form = form
        self.A = strength * form["swing_fraction"] * ctx.swing_um
        self.ref = ctx.u_lo
        self.vmax2 = device.v_max_V ** 2
        self.ctx = ctx

    def __call__(self, y, t, v_th):
        f = self.form
        ph = (2 * np.pi * (y - self.ref) / f["period_um"] + f["phase_rad"]
              + f["power_phase_rad"] * np.square(v_th) / self.vmax2 + f["drift_rad_per_h"] * t / 3600.0)
        if f["shape"] == "sine":
            s = np.sin(ph)
        else:
            F = f["finesse"]
            airy = 1.0 / (1.0 + F * np.sin(0.5 * ph) ** 2)
            s = (airy - 1.0 / math.sqrt(1.0 + F)) / (0.5 * (1.0 - 1.0 / (1.0 + F)))
        if f["envelope"] == "gaussian":
            half = 0.5 * self.ctx.swing_um
            c = 0.5 * (self.ctx.u_lo + self.ctx.u_hi) + f["envelope_centre"] * half
            s = s * np.exp(-0.5 * ((y - c) / (f["envelope_width_swing"] * self.ctx.swing_um)) ** 2)
        return y + self.A * s


def _first_point(form: dict, strength: float, ctx: DeviceContext, v: np.ndarray, vmax: float) -> np.ndarray:
    """Offset of each reading tied to the reversals of the set-point sequence (not to time)."""
    A = strength * form["swing_fraction"] * ctx.swing_um
    out = np.zeros(v.size)
    last_dir = -1.0  # the heater came down to 0 V before every run
    prev = 0.0
    state = 0.0
    r = form["linger"]
    for n, vn in enumerate(v):
        state *= r
        d = vn - prev
        prev = vn
        if d != 0.0:
            di = 1.0 if d > 0 else -1.0
            if di != last_dir:
                size = abs(d)
                law = form["size_law"]
                if law == "linear":
                    g = size / vmax * 2.0
                elif law == "saturating":
                    g = size / (size + form["size_scale_V"])
                elif law == "sqrt":
                    g = math.sqrt(size / vmax) * 1.4
                else:
                    g = 1.0
                fac = form["up_factor"] if di > 0 else form["down_factor"]
                conv = {"along": di, "against": -di, "fixed": 1.0}[form["convention"]]
                state += A * fac * g * conv
            last_dir = di
        out[n] = state
    return out


# =========================================================================== session

_ALL = LIBRARY + OUTSIDE


def _parse(effects) -> dict:
    active = {}
    for item in effects or ():
        family, form, strength = item
        if family not in _ALL:
            raise ValueError(f"unknown mechanism {family!r}")
        strength = float(strength)
        if not strength >= 0.0 or not math.isfinite(strength):
            raise ValueError(f"strength must be finite and >= 0, got {strength!r}")
        if family in active:
            raise ValueError(f"mechanism {family!r} given twice")
        if strength > 0.0:
            active[family] = (form, strength)
    return active


def _turning_points(x_prev: float, x: np.ndarray) -> list[float]:
    """The local extrema of the path (x_prev, x...) strictly inside it: the values a Preisach film remembers."""
    z = np.concatenate([[x_prev], x])
    d = np.diff(z)
    idx = np.nonzero(d[:-1] * d[1:] < 0)[0] + 1
    return [float(z[i]) for i in idx]


def simulate(device: BaseDevice, schedules, effects, seed: int, noise_um) -> list[dict]:
    """Simulate one session (see the package docstring and README.md)."""
    act = _parse(effects)
    ctx = context(device)
    k = device.kelvin_per_V2
    vmax = device.v_max_V

    lag = _ThermalLag(*act["thermal_lag"]) if "thermal_lag" in act else None
    acc = _Accommodation(*act["accommodation"], device, ctx) if "accommodation" in act else None
    film = _Film(device, ctx, act.get("interaction"), acc)
    joule = _Joule(*act["joule_power"], device, ctx) if "joule_power" in act else None
    rev = _Reversible(*act["reversible"], device, ctx) if "reversible" in act else None
    creep = _Creep(*act["creep"], ctx) if "creep" in act else None
    mount = _Mount(*act["backlash"], ctx) if "backlash" in act else None
    fringes = _Fringes(*act["spillover_fringes"], device, ctx) if "spillover_fringes" in act else None
    nl = _SensorNL(*act["sensor_nonlinearity"], ctx) if "sensor_nonlinearity" in act else None
    temperature = lag is not None or "ambient_drift" in act

    def deflection(phase, v, v_th, x):
        u = device.output(phase, v_th)
        if joule is not None:
            u += joule.extra(v_th)
        if rev is not None:
            u += rev(x if rev.use_temperature else v)
        return u

    results = []
    film_x = device.v_min_V  # the film's (equivalent) input before interaction
    for r, sch in enumerate(schedules):
        v = np.asarray(sch["v_V"], dtype=float).copy()
        dwell = np.asarray(sch["dwell_s"], dtype=float)
        K = int(sch.get("readings", 1))
        n = v.size
        gap, T, t, logged = run_timing(seed, r, dwell, K)
        t_first = float(T[0]) if n else 0.0
        t_end = float(t[-1]) + 60.0 if n else 60.0
        drifts = {}
        for fam in ("ambient_drift", "baseline_drift", "gain_drift"):
            if fam in act:
                drifts[fam] = DriftPath(act[fam][0], seed, r, fam, -gap - 60.0, t_end)
        dT_scale = 0.0
        if "ambient_drift" in act:
            form, s = act["ambient_drift"]
            dT_scale = s * form["kelvin_per_width"] * ctx.width_C

        def ambient(times):
            if "ambient_drift" not in drifts:
                return np.zeros(np.shape(times))
            return dT_scale * drifts["ambient_drift"](times)

        # ---- steps: (set-point time, reading time, voltage, index); index -1: the pause
        steps = []
        if r == 0:
            # the session starts after a long time at 0 V: settle every state there
            if temperature:
                film_x = math.sqrt(max(float(ambient(np.array([t_first]))[0]) / k, 0.0))
            phase = film.move(film_x) if (temperature or film.coupling is not None) else film.value()
            u0 = deflection(phase, 0.0, 0.0, film_x)
            if creep is not None:
                creep.rest(phase if creep.use_phase else u0)
            if mount is not None:
                mount.rest(u0)
        else:
            # the heater off for the pause, which began at the previous run's last reading
            for obj in (lag, creep):
                if obj is not None and obj.t is not None and np.isfinite(obj.t):
                    obj.t -= gap
            steps.append((-gap, t_first, 0.0, -1))
        for i in range(n):
            steps.append((float(T[i]), float(t[i]), float(v[i]), i))

        u_rec = np.zeros(n)
        vth_rec = np.zeros(n)
        for Tj, tj, vj, idx in steps:
            if temperature:
                offs = _GRID * (tj - Tj)
                if lag is not None:
                    lag.step(Tj, vj * vj)
                    Pp = lag.power(offs)
                else:
                    Pp = np.full(offs.size, vj * vj)
                xs = np.sqrt(np.maximum(Pp + ambient(Tj + offs) / k, 0.0))
                for xt in _turning_points(film_x, xs):
                    film.move(xt)
                x = float(xs[-1])
                v_th = math.sqrt(max(float(Pp[-1]), 0.0)) if lag is not None else vj
            else:
                x, v_th = vj, vj
            film_x = x
            phase = film.move(x, reset_if_cold=idx < 0)
            u = deflection(phase, vj, v_th, x)
            if creep is not None:
                u = creep.apply(Tj, tj, phase if creep.use_phase else u, u)
            if mount is not None:
                u = mount.apply(u)
            if idx >= 0:
                u_rec[idx] = u
                vth_rec[idx] = v_th
        # carry the clocks of the stateful stages to the end of this run
        t_last = float(t[-1]) if n else t_first
        for obj in (lag, creep):
            if obj is not None and obj.t is not None and np.isfinite(obj.t):
                obj.t -= t_last

        # ---- sensor
        y = u_rec
        if fringes is not None:
            y = fringes(y, t, vth_rec)
        if nl is not None:
            y = nl(y)
        if "gain_drift" in act:
            form, s = act["gain_drift"]
            eps = s * form["swing_fraction"] * ctx.swing_um / max(ctx.u_rms, 0.25 * ctx.swing_um)
            y = y * (1.0 + eps * drifts["gain_drift"](t))
        if "baseline_drift" in act:
            form, s = act["baseline_drift"]
            y = y + s * form["swing_fraction"] * ctx.swing_um * drifts["baseline_drift"](t)
        if "first_point" in act:
            y = y + _first_point(*act["first_point"], ctx, v, vmax)
        if noise_um is not None and n:
            y = y + float(noise_um) * stream(seed, r, _TAG_NOISE).standard_normal(n)
        results.append({"t_s": t.copy(), "v_V": v, "y_um": np.asarray(y, dtype=float), "dwell_s": logged.copy()})
    return results


__all__ = ["SAMPLE_PERIOD_S", "run_timing", "simulate"]
