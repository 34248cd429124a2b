"""The mechanisms as dynamical systems acting on the rig's signal chain.

Physical order (SPEC: temperature -> film -> deflection -> sensor):

    heater v(t) --> [thermal_lag: linear/nonlinear thermal network] --+--> film temperature
    room        --> [ambient_drift: SDE (+ package lag)] -------------+
    film temperature --> x (equivalent volts) --> [interaction: mean-field feedback loop]
                     --> Preisach film (base) --> [accommodation: cycle-dependent weights]
    deflection u = bias + thermal term [joule_power] + phase + [reversible]
                 --> [creep: Hammerstein-Prony relaxation] --> [backlash: play operators]
                 --> [first_point: event-driven transient]
    PSD: [optical_contrast] --> [sensor_nonlinearity] --> x (1 + [gain_drift]) + [baseline_drift]
         + noise
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import brentq, nnls
from scipy.special import erf, ndtr

from . import disturbances
from ._streams import effect_stream


# ----------------------------------------------------------------------------- device context
class DeviceContext:
    """Quantities of the drawn device used to scale the effects (major loop, swing, slopes)."""

    def __init__(self, device) -> None:
        self.device = device
        self.vmin, self.vmax = float(device.v_min_V), float(device.v_max_V)
        self.vrange = self.vmax - self.vmin
        self.S = float(device.phase_swing_um)
        xs = np.linspace(self.vmin, self.vmax, 61)
        h = device.hysteresis()
        Pu = np.array([h.move(x) for x in xs])
        Pd = np.array([h.move(x) for x in xs[::-1]])[::-1]
        uu = device.bias_um + device.thermal_um_per_V * xs + Pu
        ud = device.bias_um + device.thermal_um_per_V * xs + Pd
        allu = np.concatenate([uu, ud])
        self.umin, self.umax = float(allu.min()), float(allu.max())
        self.swing = max(self.umax - self.umin, 1e-6)
        self.urms = float(np.sqrt(np.mean(allu ** 2)))
        xm = 0.5 * (xs[1:] + xs[:-1])
        su = np.diff(Pu) / np.diff(xs)
        sd = np.diff(Pd) / np.diff(xs)
        self.slope_V = max(float(su.max()), float(sd.max()), 1e-9)
        k = float(device.kelvin_per_V2)
        pos = xm > 1e-9
        self.slope_K = max(float(np.max(su[pos] / (2 * k * xm[pos]))),
                           float(np.max(sd[pos] / (2 * k * xm[pos]))), 1e-12)
        self.x_tr_up = float(xm[int(np.argmax(su))])
        self.x_tr_dn = float(xm[int(np.argmax(sd))])
        self.xs, self.Pu, self.Pd = xs, Pu, Pd


# ----------------------------------------------------------------------------- ambient drift
class AmbientDrift:
    AMP_K = 0.25  # K at strength 1 (times the form's amp)

    def __init__(self, form, s, seed, name="ambient_drift"):
        self.form, self.scale, self.seed, self.name = form, s * float(form["amp"]) * self.AMP_K, seed, name
        self.lag = float(form.get("package_lag_s", 0.0))

    def run_path(self, run, t_change, t_read):
        times = np.empty(2 * t_change.size)
        times[0::2], times[1::2] = t_change, t_read
        x = disturbances.sample_process(self.form, effect_stream(self.seed, self.name, run), times)
        if self.lag > 0.0:  # the package low-passes the room (first order, exact for piecewise-constant)
            y = np.empty_like(x)
            y[0], tp = x[0], times[0]
            for k in range(1, x.size):
                a = math.exp(-(times[k] - tp) / self.lag)
                y[k] = a * y[k - 1] + (1 - a) * x[k]
                tp = times[k]
            x = y
        x = self.scale * x
        return x[0::2], x[1::2]


# ----------------------------------------------------------------------------- interaction
class Interaction:
    def __init__(self, form, s, device, ctx: DeviceContext):
        self.device = device
        self.k = float(device.kelvin_per_V2)
        self.kelvin = form["domain"] == "kelvin"
        S = ctx.S
        self.Pref = -S if form["reference"] == "insulating" else 0.0
        law = form["law"]
        self.S = S
        if law == "linear":
            self.M = lambda d: d
            mslope = 1.0
        elif law == "saturating":
            c = float(form["sat"]) * S
            self.M = lambda d, c=c: c * math.tanh(d / c)
            mslope = 1.0
        else:
            a = float(form["a"])
            self.M = lambda d, a=a, S=S: d + a * d * d / S
            mslope = 1.0 + 4.0 * abs(a)
        dgrid = np.linspace(-S - self.Pref, S - self.Pref, 41)
        self.Mabs = max(abs(self.M(float(d))) for d in dgrid) + 1e-12
        gain = 0.9 * math.tanh(s * float(form["gain1"]) / 0.9)
        slope = ctx.slope_K if self.kelvin else ctx.slope_V
        self.lam = float(form["sign"]) * gain / (slope * mslope)
        self.P_last = -S

    def begin_run(self):
        self.P_last = -self.S

    def _x(self, q):
        return float(self.device.equivalent_voltage(q)) if self.kelvin else q

    def solve(self, h, x):
        """The hysterons' effective input ``x_e`` with ``x_e = x + lam M(P(x_e))`` (self-consistent)."""
        q = self.k * x * x if self.kelvin else x
        lam, M, Pref = self.lam, self.M, self.Pref

        def F(qe):
            return qe - (q + lam * M(h.peek(self._x(qe)) - Pref))

        tol = 1e-10
        q0 = q + lam * M(self.P_last - Pref)
        f0 = F(q0)
        if abs(f0) < tol:
            return self._x(q0)
        q1 = q0 - f0
        f1 = F(q1)
        for _ in range(12):
            if abs(f1) < tol:
                return self._x(q1)
            if f1 == f0:
                break
            q2 = q1 - f1 * (q1 - q0) / (f1 - f0)
            q0, f0 = q1, f1
            q1, f1 = q2, F(q2)
        if abs(f1) < tol:
            return self._x(q1)
        span = abs(lam) * self.Mabs + 1e-9
        return self._x(brentq(F, q - span, q + span, xtol=1e-12, rtol=1e-14))


# ----------------------------------------------------------------------------- accommodation
class Accommodation:
    N_REF = 15.0

    def __init__(self, form, s, device, ctx: DeviceContext):
        self.device, self.ctx = device, ctx
        self.pattern = form["pattern"]
        self.law = form["law"]
        self.N0, self.p = float(form["N0"]), float(form["p"])
        self.N_pre = float(form["N_pre"])
        self.N = 0.0
        self.S = ctx.S
        aux_dev = device
        self.map = None
        if self.pattern == "shift":
            hV = float(form["shift_V"])
            self.map = lambda x, hV=hV: x + hV
        elif self.pattern == "broaden":
            xc = 0.5 * (ctx.x_tr_up + ctx.x_tr_dn)
            b = 1.0 + float(form["broaden"])
            self.map = lambda x, xc=xc, b=b: xc + (x - xc) / b
        elif self.pattern == "random_cells":
            rng = np.random.default_rng(int(form["field_seed"]))
            xi = rng.standard_normal(np.asarray(device.density_um).size)
            delta = np.maximum(1.0 + float(form["sigma"]) * xi, 0.0)
            aux_dev = dataclasses.replace(device, density_um=np.asarray(device.density_um) * delta)
            self.map = lambda x: x
        self.aux_dev = aux_dev
        # the pattern's size over a major loop
        if self.pattern == "uniform":
            mx = self.S
        else:
            h = aux_dev.hysteresis()
            pu = np.array([h.move(self.map(x)) for x in ctx.xs])
            pd = np.array([h.move(self.map(x)) for x in ctx.xs[::-1]])[::-1]
            if self.pattern == "random_cells":
                mx = max(np.max(np.abs(pu)), np.max(np.abs(pd)))
            else:
                mx = max(np.max(np.abs(pu - ctx.Pu)), np.max(np.abs(pd - ctx.Pd)))
        df = self._f(self.N_pre + self.N_REF) - self._f(self.N_pre)
        self.A = float(form["sign"]) * s * float(form["amp_frac"]) * ctx.swing / (max(mx, 1e-9) * df)
        self.aux = None
        self.P_prev = -self.S
        self.P_aux = 0.0

    def _f(self, N):
        if self.law == "exponential":
            return 1.0 - math.exp(-N / self.N0)
        if self.law == "logarithmic":
            return math.log1p(N / self.N0)
        if self.law == "power":
            return (N / self.N0) ** self.p
        return N / self.N0

    def begin_run(self):
        if self.map is not None:
            self.aux = self.aux_dev.hysteresis()
            self.P_aux = self.aux.value()
        self.P_prev = -self.S

    def move(self, x_e, P):
        if self.aux is not None:
            self.P_aux = self.aux.move(self.map(x_e))
        self.N += abs(P - self.P_prev) / (4.0 * self.S)
        self.P_prev = P

    def end_run(self):
        self.N += abs(-self.S - self.P_prev) / (4.0 * self.S)
        self.P_prev = -self.S

    def term(self, P):
        if self.pattern == "uniform":
            pd = P
        elif self.pattern == "random_cells":
            pd = self.P_aux
        else:
            pd = self.P_aux - P
        return self.A * (self._f(self.N_pre + self.N) - self._f(self.N_pre)) * pd


# ----------------------------------------------------------------------------- joule power
class JoulePower:
    def __init__(self, form, s, device, ctx: DeviceContext):
        k = float(device.kelvin_per_V2)
        vmax = ctx.vmax
        v = np.linspace(0.0, vmax, 1201)
        theta = k * v * v
        Ta = float(device.ambient_C)
        law = form["alpha_law"]
        tmax = k * vmax * vmax
        if law == "constant":
            alpha = np.ones_like(theta)
        elif law == "linear":
            alpha = np.maximum(1.0 + float(form["beta"]) * theta / tmax, 0.05)
        elif law == "kelvin_power":
            alpha = ((Ta + theta + 273.15) / (Ta + 273.15)) ** float(form["q"])
        elif law == "transition_step":
            Tm = 0.5 * (float(device.transition_heating_C) + float(device.transition_cooling_C))
            w = float(device.transition_width_C) * float(form["width_factor"])
            alpha = 1.0 + float(form["step"]) * 0.5 * (1.0 + np.tanh((Ta + theta - Tm) / w))
        else:
            alpha = 1.0 / (1.0 + theta / float(form["theta_s_K"]))
        D = np.concatenate([[0.0], np.cumsum(0.5 * (alpha[1:] + alpha[:-1]) * np.diff(theta))])
        d = vmax * D / D[-1] - v
        self.v, self.d = v, d
        dmax = max(float(np.max(np.abs(d))), 1e-9)
        cT = abs(float(device.thermal_um_per_V))
        self.kappa = s * float(form["amp_frac"]) * ctx.swing / (max(cT, 1e-6) * dmax)

    def map(self, v_th):
        return v_th + self.kappa * float(np.interp(v_th, self.v, self.d))


# ----------------------------------------------------------------------------- reversible
class Reversible:
    def __init__(self, form, s, device, ctx: DeviceContext):
        self.arg = form["arg"]
        self.k = float(device.kelvin_per_V2)
        self.Ta = float(device.ambient_C)
        self.vmax = ctx.vmax
        shape = form["shape"]
        Tm = 0.5 * (float(device.transition_heating_C) + float(device.transition_cooling_C))
        if shape in ("sigmoid", "bump"):
            Tc = Tm + float(form["centre_offset_K"])
            w = float(form["width_K"])
            if shape == "sigmoid":
                self.f = lambda a: np.tanh((self.Ta + self.k * a * a - Tc) / w)
            else:
                self.f = lambda a: np.exp(-0.5 * ((self.Ta + self.k * a * a - Tc) / w) ** 2)
        elif shape == "power":
            p = float(form["p"])
            self.f = lambda a: np.power(np.clip(a / self.vmax, 0.0, None), p)
        elif shape == "legendre":
            c = [float(x) for x in form["coeffs"]]

            def f(a, c=c):
                z = 2.0 * np.asarray(a) / self.vmax - 1.0
                return (c[0] * 0.5 * (3 * z ** 2 - 1) + c[1] * 0.5 * (5 * z ** 3 - 3 * z)
                        + c[2] * 0.125 * (35 * z ** 4 - 30 * z ** 2 + 3))
            self.f = f
        else:
            sc = float(form["scale"])
            self.f = lambda a: np.exp(np.asarray(a) / self.vmax / sc)
        grid = np.linspace(0.0, self.vmax, 601)
        vals = self.f(grid)
        A = np.vstack([np.ones_like(grid), grid]).T
        coef, *_ = np.linalg.lstsq(A, vals, rcond=None)
        res = vals - A @ coef
        self.c0, self.c1 = float(coef[0]), float(coef[1])
        self.norm = max(float(np.max(np.abs(res))), 1e-12)
        self.amp = s * float(form["sign"]) * float(form["amp_frac"]) * ctx.swing

    def term(self, v, x):
        a = v if self.arg == "heater" else x
        return self.amp * (float(self.f(np.float64(a))) - self.c0 - self.c1 * a) / self.norm


# ----------------------------------------------------------------------------- creep
_TAU_GRID = np.geomspace(0.5, 1e5, 36)
_T_FIT = np.geomspace(0.1, 3e5, 240)


def creep_kernel(form) -> tuple[np.ndarray, np.ndarray]:
    """Prony weights (sum 1) and time constants of the relaxation kernel K(t), K(0) = 1."""
    kern = form["kernel"]
    if kern == "prony":
        w = np.array(form["weights"], float)
        return w / w.sum(), np.array(form["taus_s"], float)
    if kern == "lognormal":
        lt = np.log(_TAU_GRID)
        w = np.exp(-0.5 * ((lt - math.log(float(form["tau_m_s"]))) / float(form["sigma_ln"])) ** 2)
        return w / w.sum(), _TAU_GRID.copy()
    if kern == "kww":
        K = np.exp(-(_T_FIT / float(form["tau_s"])) ** float(form["beta"]))
    else:
        K = (1.0 + _T_FIT / float(form["t0_s"])) ** (-float(form["n"]))
    E = np.exp(-_T_FIT[:, None] / _TAU_GRID[None, :])
    w, _ = nnls(E, K)
    keep = w > 0
    w, tau = w[keep], _TAU_GRID[keep]
    return w / w.sum(), tau


class Creep:
    """Generalised Maxwell (Prony) relaxation with power-law (Norton) dashpots.

    Mode ``i`` holds the lag ``e_i = z_i - u`` of its relaxed shape behind the driving signal
    (the deflection or its phase part); between changes of the signal it relaxes exactly as

        de/dt = -sgn(e) |e|^n / (tau_i rho_dir D^(n-1))

    (``n`` the Norton exponent, ``rho_dir`` a direction-dependent factor of the time constant),
    and a change of the signal by ``delta`` sets ``e_i -= delta``.  The reading is
    ``u + sign c sum_i w_i e_i (1 + a sgn(e_i))``: short of the change (sign +) or beyond it
    (sign -), creeping on towards it.  Every ``|e_i|`` stays within the signal's range: bounded.
    """

    CMAX = 0.5

    def __init__(self, form, s, device, ctx: DeviceContext):
        self.w, self.tau = creep_kernel(form)
        K20 = float(np.sum(self.w * np.exp(-20.0 / self.tau)))
        c1 = float(form["resid_frac"]) / max(K20, 1e-3)
        self.c = self.CMAX * (1.0 - math.exp(-s * c1 / self.CMAX))
        self.phase = form["driver"] == "phase"
        self.n = float(form["norton_n"])
        rho = float(form["rho"])
        self.tau_up = self.tau * math.sqrt(rho)  # e < 0: creeping upwards
        self.tau_dn = self.tau / math.sqrt(rho)
        self.asym, self.sign = float(form["asym"]), float(form["sign"])
        self.D = ctx.swing
        self.e = np.zeros(self.tau.size)
        self.t_last = 0.0
        self.prev = float(device.bias_um) - ctx.S if not self.phase else -ctx.S

    def _evolve(self, dt):
        e = self.e
        if dt <= 0.0:
            return e.copy()
        tau = np.where(e < 0.0, self.tau_up, self.tau_dn)
        if self.n == 1.0:
            return e * np.exp(-dt / tau)
        a = np.abs(e) / self.D
        out = np.zeros_like(e)
        nz = a > 0.0
        base = a[nz] ** (1.0 - self.n) + (self.n - 1.0) * dt / tau[nz]
        out[nz] = np.sign(e[nz]) * self.D * np.maximum(base, 0.0) ** (1.0 / (1.0 - self.n))
        return out

    def event(self, value, t_abs):
        """The driving signal changes to ``value`` at ``t_abs``."""
        self.e = self._evolve(t_abs - self.t_last) - (value - self.prev)
        self.t_last = t_abs
        self.prev = value

    def offset(self, t_abs):
        e = self._evolve(t_abs - self.t_last)
        return self.sign * self.c * float(np.sum(self.w * e * (1.0 + self.asym * np.sign(e))))


# ----------------------------------------------------------------------------- backlash
class Backlash:
    def __init__(self, form, s, device, ctx: DeviceContext):
        self.kind = form["kind"]
        r = s * float(form["r_frac"]) * ctx.swing
        if self.kind == "prandtl_ishlinskii":
            self.r = 2.0 * r * np.array(form["radii"], float)
            self.wts = np.array(form["weights"], float)
        else:
            self.r = np.array([r])
            self.wts = np.array([1.0])
        self.follow = float(form.get("follow", 0.0)) if self.kind == "compliant_play" else 0.0
        self.take_up = float(form.get("take_up", 1.0))
        y0 = float(device.bias_um) - ctx.S  # at rest; the last motion was downwards
        self.y = y0
        self.z = y0 + self.r  # each play's mount position (came down: mount above)

    def move(self, y):
        dy = y - self.y
        if self.kind == "smooth_play":
            e0 = self.y - self.z  # the lag before the move
            if dy != 0.0:
                esat = np.sign(dy) * self.r
                e = esat - (esat - e0) * np.exp(-abs(dy) / (self.take_up * self.r))
                self.z = y - e
        elif self.kind == "compliant_play":
            # a compliant mount: inside the play the mount follows a fraction of the motion
            self.z = np.clip(self.z + self.follow * dy, y - self.r, y + self.r)
        else:
            self.z = np.clip(self.z, y - self.r, y + self.r)
        self.y = y
        return float(np.sum(self.wts * self.z))


# ----------------------------------------------------------------------------- first point
class FirstPoint:
    def __init__(self, form, s, device, ctx: DeviceContext):
        self.f = form
        self.A = s * float(form["amp_frac"]) * ctx.swing
        self.sense = 1.0 if form["sense"] == "overshoot" else -1.0
        self.vr, self.D = ctx.vrange, ctx.swing
        self.begin_run()

    def begin_run(self):
        self.last_dir = 0
        self.events: list[tuple[int, float]] = []
        self.n = -1
        self.v_prev, self.u_prev = None, None

    def _h(self, size):
        law = self.f["size_law"]
        ref = 0.5 * self.vr
        if law == "const":
            return 1.0
        if law == "linear":
            return min(size / ref, 2.0)
        if law == "sqrt":
            return min(math.sqrt(size / ref), 1.5)
        return 1.0 - math.exp(-size / float(self.f["s0_V"]))

    def _lag(self, k):
        ling = self.f["linger"]
        if ling == "none":
            return 1.0 if k == 0 else 0.0
        if ling == "geometric":
            return float(self.f["rho"]) ** k
        return max(0.0, 1.0 - k / (int(self.f["n_steps"]) + 1.0))

    def offset(self, v, u):
        self.n += 1
        if self.v_prev is not None:
            dv = v - self.v_prev
            d = 1 if dv > 1e-12 else (-1 if dv < -1e-12 else 0)
            if d != 0:
                if self.last_dir != 0 and d != self.last_dir:
                    if self.f["driver"] == "input":
                        size = abs(dv)
                    else:
                        size = abs(u - self.u_prev) * self.vr / self.D
                    a = float(self.f["asym"])
                    amp = self.A * self.sense * d * (1.0 + a * d) / (1.0 + abs(a)) * self._h(size)
                    self.events.append((self.n, amp))
                self.last_dir = d
        else:
            self.last_dir = 0 if v <= 1e-12 else 1  # from a long rest at 0 V: not a reversal
        self.v_prev, self.u_prev = v, u
        total = 0.0
        keep = []
        for n0, amp in self.events:
            lw = self._lag(self.n - n0)
            if lw > 1e-9:
                total += amp * lw
                keep.append((n0, amp))
        self.events = keep
        return total


# ----------------------------------------------------------------------------- optical contrast
class OpticalContrast:
    """Own outside mechanism: the PSD's sensitivity follows the film's reflectance (its phase)."""

    def __init__(self, form, s, device, ctx: DeviceContext):
        self.f = form
        self.S = ctx.S
        mid = 0.5 * (ctx.umin + ctx.umax)
        self.xb = mid + float(form["background_frac"]) * 0.5 * ctx.swing
        lever = max(abs(ctx.umin - self.xb), abs(ctx.umax - self.xb), 1e-6)
        self.g = s * float(form["sign"]) * float(form["amp_frac"]) * ctx.swing / lever

    def _h(self, m):
        law = self.f["law"]
        if law == "linear":
            return m
        if law == "saturating":
            m0 = float(self.f["m0"])
            return (1.0 - math.exp(-m / m0)) / (1.0 - math.exp(-1.0 / m0))
        if law == "percolation":
            mc, sh = float(self.f["m_c"]), float(self.f["sharp"])
            lo, hi = math.tanh(-mc / sh), math.tanh((1.0 - mc) / sh)
            return (math.tanh((m - mc) / sh) - lo) / (hi - lo)
        return m * m

    def apply(self, y, P):
        m = min(max(0.5 * (P / self.S + 1.0), 0.0), 1.0)
        return self.xb + (y - self.xb) * (1.0 + self.g * self._h(m))


# ----------------------------------------------------------------------------- sensor nonlinearity
def _shape_fn(form):
    shape = form["shape"]
    if shape == "tanh":
        return np.tanh
    if shape == "arctan":
        return np.arctan
    if shape == "erf":
        c = math.sqrt(math.pi) / 2.0
        return lambda z: erf(c * np.asarray(z))
    if shape == "algebraic":
        q = float(form["q"])
        return lambda z: np.asarray(z) / (1.0 + np.abs(z) ** q) ** (1.0 / q)
    if shape == "exponential":
        a = float(form["a"])
        return lambda z: (1.0 - np.exp(-a * np.asarray(z))) / a
    sig = float(form["spot_ratio"])

    def centroid(z):
        z = np.clip(np.asarray(z, float), -1.0 - 6.0 * sig, 1.0 + 6.0 * sig)
        a, b = (-1.0 - z) / sig, (1.0 - z) / sig
        phi = lambda t: np.exp(-0.5 * t * t) / math.sqrt(2 * math.pi)
        return z + sig * (phi(a) - phi(b)) / np.maximum(ndtr(b) - ndtr(a), 1e-300)

    c0 = float((centroid(1e-6) - centroid(-1e-6)) / 2e-6)
    return lambda z: centroid(z) / c0


class SensorNonlinearity:
    def __init__(self, form, s, device, ctx: DeviceContext):
        self.g = _shape_fn(form)
        mid, half = 0.5 * (ctx.umin + ctx.umax), 0.5 * ctx.swing
        self.uc = mid + float(form["centre_frac"]) * half
        u = np.linspace(ctx.umin, ctx.umax, 201)
        A = np.vstack([np.ones_like(u), u]).T
        target = float(form["amp_frac"]) * ctx.swing

        def dev(eps):
            y = self.uc + self.g(eps * (u - self.uc)) / eps
            coef, *_ = np.linalg.lstsq(A, y, rcond=None)
            # the part no gain and offset absorbs, but also the whole change at most 3 times that
            return max(float(np.max(np.abs(y - A @ coef))), float(np.max(np.abs(y - u))) / 3.0)

        lo, hi = 1e-6 / ctx.swing, 1e-6 / ctx.swing
        while dev(hi) < target and hi < 1e3:
            hi *= 2.0
        for _ in range(50):
            mid_e = math.sqrt(lo * hi)
            if dev(mid_e) < target:
                lo = mid_e
            else:
                hi = mid_e
        # the deviation grows like eps**2 for the odd shapes (like eps for the exponential one):
        # scale eps so that the deviation grows about linearly with the strength at small strengths
        order = 1.0 if form["shape"] == "exponential" else 0.5
        self.eps = s ** order * math.sqrt(lo * hi)

    def apply(self, y):
        return self.uc + float(self.g(self.eps * (y - self.uc))) / self.eps


# ----------------------------------------------------------------------------- slow sensor drifts
class SensorDrift:
    """Baseline (additive, um) or gain (relative) drift of the PSD: a unit SDE path times a scale."""

    def __init__(self, name, form, s, seed, ctx: DeviceContext):
        self.name, self.form, self.seed = name, form, seed
        if name == "baseline_drift":
            self.scale = s * float(form["amp"]) * 0.01 * ctx.swing
        else:
            rel = min(0.01 * ctx.swing / max(ctx.urms, 1e-6), 0.04)
            self.scale = s * float(form["amp"]) * rel

    def run_path(self, run, t_read):
        return self.scale * disturbances.sample_process(self.form, effect_stream(self.seed, self.name, run), t_read)
