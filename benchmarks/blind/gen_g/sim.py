"""Generator G's session simulator: the base device plus the mechanisms, in their physical order.

temperature (ambient drift, slow heat paths)  ->  film (mean-field interaction, accommodation,
nucleation after-effect, the base Preisach)  ->  deflection (bimorph term, reversible strain, creep,
mechanical first-point transient, play in the lever's mount)  ->  sensor (PSD nonlinearity, gain
drift, zero drift, electronic first-point transient)  ->  noise.

Streams (all from ``seed``): run ``r``'s timing ``stream(seed, 2, r)``, its noise ``stream(seed, 1, r)``,
a mechanism's run ``r`` realisation ``stream(seed, 3, crc32(name), r, ...)`` and its session-wide
constants ``stream(seed, 4, crc32(name))``.  A run never draws from a later run's streams, so a
session with one more run appended repeats the first runs exactly.
"""

from __future__ import annotations

import numpy as np

from .film import GrainTracker, cell_bands, density_grid, slopes
from .forms import LIBRARY, OUTSIDE
from .kernels import Drift, spectrum, stream

# ---- the lab's logger ---------------------------------------------------------------------------
SAMPLE_RATE_HZ = 1000.0      # the PSD burst: K samples at 1 kHz
LOG_RESOLUTION_S = 1e-3      # the logger writes times in milliseconds
GAP_S = (540.0, 720.0)       # the heater off between two runs ("about ten minutes")


def timing(seed: int, r: int, dwell_s: np.ndarray, K: int):
    """Run ``r``'s clock: (set-point times, reading times, gap before the run), in s, exact.

    The host's timer overshoots every dwell by a few ms (a gamma-distributed latency, now and then a
    hiccup of 0.1-1.5 s); the burst starts 1-3 ms after the timer fires and lasts ``K / 1 kHz``; the
    reading's time is the burst's centre; writing the log line takes a few ms before the next set-point.
    """
    rng = stream(seed, 2, r)
    n = len(dwell_s)
    latency = 0.003 + rng.gamma(2.0, 0.006, n)
    hiccup = rng.random(n) < 0.01
    latency = latency + hiccup * rng.uniform(0.1, 1.5, n)
    start = rng.uniform(0.001, 0.003, n)
    overhead = 0.002 + rng.exponential(0.004, n)
    gap = float(rng.uniform(*GAP_S))
    to_read = dwell_s + latency + start + 0.5 * (K - 1) / SAMPLE_RATE_HZ
    step = dwell_s + latency + start + K / SAMPLE_RATE_HZ + overhead
    t_set = np.concatenate([[0.0], np.cumsum(step)])   # n + 1: the last is when the heater goes off
    return t_set, t_set[:-1] + to_read, gap


# ---- device constants -----------------------------------------------------------------------------

class _Dev:
    def __init__(self, device) -> None:
        self.d = device
        self.S = device.phase_swing_um
        self.swing = 2.0 * self.S
        self.k = device.kelvin_per_V2
        self.vmax = device.v_max_V
        self.c_th = device.thermal_um_per_V
        self.slope, self.v_mid = slopes(device)
        # the input shift (V) that moves the output by 1 % of the swing where the loop is steepest
        self.vf = 0.01 * self.swing / self.slope
        # ...and the same in kelvin at the steepest point
        self.kf = self.vf * 2.0 * self.k * max(self.v_mid, 0.5)
        # the clean major loop's range of deflection (a sweep up and down)
        h = device.hysteresis()
        sweep = np.concatenate([np.linspace(device.v_min_V, device.v_max_V, 41), np.linspace(device.v_max_V, device.v_min_V, 41)[1:]])
        u = np.array([device.output(h.move(x), x) for x in sweep])
        self.u_lo, self.u_hi = float(u.min()), float(u.max())
        self.u_mid = 0.5 * (self.u_lo + self.u_hi)


# ---- temperature ----------------------------------------------------------------------------------

class ThermalLag:
    """Slow heat paths: film rise ``k [P + sum a_i (p_i - P) exp(-t / tau_i)]`` after a step to ``P = v^2``."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.dev = dev
        taus, w = spectrum(form["paths"])
        A = 2.0 * s * form["size"] * dev.kf / (dev.k * dev.vmax**2)
        self.taus, self.a = taus, A * w
        self.cool = form["cooling_factor"]
        self.share = form["expansion_share"]
        ov = form.get("overshoot")
        self.eps = 0.0 if ov is None else A * ov["ratio"]
        self.tau_o = 1.0 if ov is None else ov["tau_s"]
        self.p = np.zeros_like(taus)   # each path's filtered power (V^2): long at 0 V before the session
        self.q = 0.0                   # the heater trace's filtered power (overshoot path)

    def _taus(self, P):
        return self.taus * np.where(self.p > P, self.cool, 1.0)

    def rise(self, v, t):
        """(film rise, expansion-term rise) in K at times ``t`` (s) after the set-point ``v``."""
        P = v * v
        e = np.exp(-np.asarray(t)[:, None] / self._taus(P)[None, :])
        slow = e @ (self.a * (self.p - P))
        over = 0.0
        if self.eps:
            qt = P + (self.q - P) * np.exp(-np.asarray(t) / self.tau_o)
            over = P * self.eps * (P - qt) / self.dev.vmax**2
        k = self.dev.k
        return k * (P + slow + over), k * (P + self.share * slow + over)

    def advance(self, v, dt):
        P = v * v
        self.p = P + (self.p - P) * np.exp(-dt / self._taus(P))
        self.q = P + (self.q - P) * np.exp(-dt / self.tau_o)


class Ambient:
    """The room (through the package's low-pass) drifts: a temperature offset (K) of the film."""

    def __init__(self, form, s, dev: _Dev, seed) -> None:
        self.drift = Drift(form["components"], seed, "ambient_drift")
        self.amp = s * form["size"] * dev.kf * 1.2
        self.tau = form["package_tau_s"]
        self.y, self.t = None, None

    def run(self, r, t_sess, run_start):
        x = self.drift.run(r, t_sess, run_start)
        out = np.empty_like(x)
        y, tp = self.y, self.t
        for i, (ti, xi) in enumerate(zip(t_sess, x)):
            if y is None:
                y = xi
            else:
                y = xi + (y - xi) * np.exp(-(ti - tp) / self.tau)
            out[i], tp = y, ti
        self.y, self.t = y, tp
        return self.amp * out


# ---- film -------------------------------------------------------------------------------------------

class Interaction:
    """Mean field: the hysterons feel ``x + g * phi(phase / S)``, solved self-consistently."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.dev = dev
        self.gV = s * form["sign"] * form["size"] * 0.015 * dev.S / dev.slope * 2.0
        self.f0 = form["reference"]
        self.q = form["curvature"]

    def field(self, phase):
        f = phase / self.dev.S
        return self.gV * ((f - self.f0) + 0.5 * self.q * (f * f - self.f0 * self.f0))

    def solve(self, h, x, last_phase):
        x0 = x + self.field(last_phase)
        f0 = x0 - x - self.field(h.peek(x0))
        if abs(f0) < 1e-12:
            return x0
        x1 = x0 - f0
        for _ in range(40):
            f1 = x1 - x - self.field(h.peek(x1))
            if abs(f1) < 1e-11:
                break
            den = f1 - f0
            x2 = x1 - f1 * (x1 - x0) / den if den != 0.0 else x1 - f1
            if not np.isfinite(x2):
                x2 = x1 - f1
            x0, f0, x1 = x1, f1, x2
        return x1


class Accommodation:
    """The film's weights change with its use (cycles through the transition), cell by cell."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.dev = dev
        d = dev.d
        self.tracker = GrainTracker(d)
        self.form = form
        L = d.levels
        dv = (d.v_max_V - d.v_min_V) / L
        up, down = cell_bands(L)
        g = density_grid(d)
        ga = np.gradient(g, dv, axis=0)[up, down]   # d density / d alpha (um/V per cell)
        gb = np.gradient(g, dv, axis=1)[up, down]   # d density / d beta
        dens = np.asarray(d.density_um, dtype=float)
        width = (up - down) * dv
        wn = (width - np.average(width, weights=dens + 1e-30)) / (np.std(width) + 1e-12)
        # per unit of the use law: an amplitude change, a narrowing of the loop, a shift of the transition
        self.d_uniform = s * form["size"] * form["uniform"] * 0.02 * dens * np.clip(1 + 0.5 * form["width_bias"] * wn, 0.0, None)
        da = s * form["size"] * (-form["narrowing"] + form["shift"]) * dev.vf
        db = s * form["size"] * (form["narrowing"] + form["shift"]) * dev.vf
        self.d_shift = -(da * ga + db * gb)

    def law(self, n):
        f = self.form
        if f["law"] == "exp":
            return 1.0 - np.exp(-n / f["n0"])
        if f["law"] == "log":
            return np.log1p(n / f["n0"]) / np.log1p(50.0 / f["n0"])
        return (n / 50.0) ** f["p"]

    def delta(self):
        t = self.tracker
        if self.form["counting"] == "per_grain":
            lw = self.law(t.cell_cycles())
        else:
            lw = self.law(t.film_cycles())
        return float(np.sum((self.d_uniform + self.d_shift) * lw * t.cell_state()))


class Aftereffect:
    """Thermally activated switching of grains near their threshold: the front keeps advancing at rest."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.form = form
        self.amp = s * form["size"] * dev.vf
        self.ratio = form["heat_cool_ratio"]
        self.h30 = self._h(30.0)

    def _h(self, t):
        f = self.form
        t = np.maximum(np.asarray(t, dtype=float), 0.0)
        if f["law"] == "log":
            return np.log1p(t / f["tau0_s"])
        if f["law"] == "power":
            return (t / f["tau0_s"]) ** f["p"]
        return 1.0 - np.exp(-((t / f["tau_s"]) ** f["beta"]))

    def offset(self, direction, t_hold):
        a = self.amp * (np.sqrt(self.ratio) if direction > 0 else 1.0 / np.sqrt(self.ratio))
        return direction * a * self._h(t_hold) / self.h30


# ---- deflection ---------------------------------------------------------------------------------------

class Joule:
    def __init__(self, form, s, dev: _Dev) -> None:
        self.p, self.b, self.vmax = form["exponent"], form["expansion_curvature"], dev.vmax
        v = np.linspace(0.0, dev.vmax, 241)
        dev_max = np.max(np.abs(dev.c_th * (self._phi(v) - v)))
        self.kappa = s * form["size"] * 0.01 * dev.swing / max(dev_max, 1e-12)

    def _phi(self, v):
        r = (np.maximum(v, 0.0) / self.vmax) ** self.p
        return self.vmax * (r + 0.5 * self.b * r * r) / (1.0 + 0.5 * self.b)

    def __call__(self, vth):
        return vth + self.kappa * (self._phi(vth) - vth)


class Reversible:
    def __init__(self, form, s, dev: _Dev) -> None:
        self.form = form
        v = np.linspace(0.0, dev.vmax, 241)
        f = self._f(v) - self._f(0.0)
        self.norm = 1.0 / max(np.max(np.abs(f)), 1e-12)
        self.amp = s * form["sign"] * form["size"] * 0.01 * dev.swing
        self.f0 = float(self._f(0.0))
        self.vmax = dev.vmax

    def _f(self, x):
        f = self.form
        x = np.asarray(x, dtype=float)
        if f["shape"] == "sigmoid":
            return np.tanh((x - f["centre_V"]) / f["width_V"])
        if f["shape"] == "bump":
            return np.exp(-0.5 * ((x - f["centre_V"]) / f["width_V"]) ** 2)
        if f["shape"] == "power":
            return (np.maximum(x, 0.0) / 6.0) ** f["power"]
        return np.exp((x - 6.0) / f["scale_V"])

    def __call__(self, v, x):
        xi = v if self.form["input"] == "heater" else x
        return float(self.amp * self.norm * (self._f(xi) - self.f0))


class Creep:
    """Visco-elastic relaxation after every change of the deflection (or of its phase part).

    Every relaxation time ``tau_i`` has a state ``c_i`` (the shape the beam's slow element still
    remembers) relaxing towards the present driver ``D``; the reading is off by
    ``sum_i coef_i G(c_i - D)``: ``G`` makes the amount depend on the size and direction of the
    change that opened the gap, and the gap (hence the effect) stays bounded however many cycles.
    """

    def __init__(self, form, s, dev: _Dev, rest: float) -> None:
        self.form = form
        taus, coef = [], []
        for b in form["branches"]:
            t, w = spectrum(b["spectrum"])
            taus.append(t)
            # a lagging branch (sign -1) leaves the reading behind the driver: + G(c - D)
            coef.append(-b["sign"] * b["weight"] * w)
        self.taus = np.concatenate(taus)
        self.coef = s * form["size"] * 0.02 * np.concatenate(coef)
        self.c = np.full_like(self.taus, rest)
        self.D = rest
        self.t_ev = 0.0
        self.ref = dev.S

    def g(self, gap):
        f = self.form
        sg = np.sign(gap)
        return self.ref * sg * np.abs(gap / self.ref) ** f["exponent"] * (1.0 + f["asymmetry"] * sg)

    def event(self, t, driver):
        """The driver changes to ``driver`` at session time ``t``."""
        self.c = self.D + (self.c - self.D) * np.exp(-(t - self.t_ev) / self.taus)
        self.D, self.t_ev = driver, t

    def value(self, t):
        gap = (self.c - self.D) * np.exp(-(t - self.t_ev) / self.taus)
        return float(np.sum(self.coef * self.g(gap)))


class FirstPoint:
    def __init__(self, form, s, dev: _Dev) -> None:
        self.form = form
        self.unit = s * 0.01 * dev.swing
        self.reset()

    def reset(self):
        self.prev_dir = 0
        self.off = 0.0

    def step(self, dv, du):
        """Offset of this set-point's reading: ``dv`` the input step, ``du`` the output step (no transient)."""
        f = self.form
        self.off *= f["linger"]
        if dv == 0.0:
            return self.off
        d = 1 if dv > 0 else -1
        if self.prev_dir != 0 and d != self.prev_dir:
            a = f["amp_up"] if d > 0 else f["amp_down"]
            x = abs(dv)
            law = f["size_law"]
            size = (1.0 if law == "constant" else x / 3.0 if law == "linear"
                    else 1.0 - np.exp(-x / f["v0_V"]) if law == "saturating" else np.sqrt(x / 6.0))
            ref = f["reference"]
            sg = d if ref == "input" else (np.sign(du) if ref == "output" else 1.0)
            self.off += self.unit * a * size * sg
        self.prev_dir = d
        return self.off


class Backlash:
    """Play in the optical lever's mount: the mount (the reading) follows only once the play is taken up."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.form = form
        b = s * form["size"] * 0.01 * dev.swing
        if form["kind"] == "distributed":
            self.b = b * np.array(form["widths"])
            self.w = np.array(form["weights"])
        else:
            self.b = np.array([b])
            self.w = np.array([1.0])
        a = form["asym"]
        self.lo, self.hi = self.b * (1 - a), self.b * (1 + a)   # e = mount - beam in [-lo, hi]
        self.e = form["init"] * np.where(form["init"] > 0, self.hi, self.lo)
        self.u = None

    def __call__(self, u):
        if self.u is None:
            self.u = u
        du = u - self.u
        self.u = u
        if du != 0.0:
            W = self.lo + self.hi
            if self.form["kind"] == "dahl":
                n = self.form["sharpness"]
                y = (self.e + self.lo) if du > 0 else (self.hi - self.e)
                y = np.clip(y, 0.0, W)
                x = abs(du)
                Wp = np.where(W > 0, W, 1.0)
                if abs(n - 1.0) < 1e-9:
                    y = y * np.exp(-x / Wp)
                else:
                    with np.errstate(divide="ignore"):
                        base = np.where(y > 0, (y / Wp) ** (1.0 - n), np.inf) + (n - 1.0) * x / Wp
                    y = Wp * base ** (1.0 / (1.0 - n))
                self.e = (y - self.lo) if du > 0 else (self.hi - y)
            else:
                self.e = np.clip(self.e - du, -self.lo, self.hi)
        return u + float(self.w @ self.e)


# ---- sensor ----------------------------------------------------------------------------------------

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


class SensorNL:
    """The PSD's local sensitivity ``exp(s kappa l(xi))`` across its face; the reading is its integral."""

    def __init__(self, form, s, dev: _Dev) -> None:
        self.form = form
        half = 0.5 * (dev.u_hi - dev.u_lo)
        self.D = half
        self.c = dev.u_mid + form["centre"] * half
        u = np.linspace(dev.u_lo, dev.u_hi, 81)
        lin = self._integral(u, 1.0, linear=True)
        self.kappa = s * form["size"] * 0.01 * dev.swing / max(np.max(np.abs(lin)), 1e-12)

    def _l(self, xi):
        f = self.form
        p = f["profile"]
        if p == "edges":
            return -xi * xi
        if p == "edge_power":
            return -np.abs(xi) ** f["power"]
        if p == "tilt":
            return f["tilt"] * xi
        if p == "offcentre":
            return -xi * xi + f["tilt"] * xi
        return -xi * xi * (1.0 + f["asym"] * np.tanh(2.0 * xi))

    def _integral(self, u, kappa, linear=False):
        u = np.asarray(u, dtype=float)
        half = 0.5 * (u - self.c)
        nodes = self.c + half[:, None] * (1.0 + _GL_X[None, :])
        lv = self._l((nodes - self.c) / self.D)
        integrand = lv if linear else np.expm1(kappa * lv)
        return half * (integrand @ _GL_W)

    def __call__(self, u):
        # y = u + integral of (sensitivity - 1): exact identity at kappa = 0
        return u + self._integral(u, self.kappa)


# ---- the session ------------------------------------------------------------------------------------

_KNOWN = set(LIBRARY) | set(OUTSIDE)


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md and README.md)."""
    eff = {}
    for family, form, strength in effects:
        if family not in _KNOWN:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if s < 0 or not np.isfinite(s):
            raise ValueError("strength must be finite and >= 0")
        if s > 0.0:
            eff[family] = (form, s)
    dev = _Dev(device)

    def make(name, cls, *extra):
        if name not in eff:
            return None
        form, s = eff[name]
        return cls(form, s, dev, *extra)

    lag = make("thermal_lag", ThermalLag)
    amb = make("ambient_drift", Ambient, seed)
    inter = make("interaction", Interaction)
    acc = make("accommodation", Accommodation)
    after = make("nucleation_aftereffect", Aftereffect)
    joule = make("joule_power", Joule)
    rev = make("reversible", Reversible)
    creep = None
    fp = make("first_point", FirstPoint)
    back = make("backlash", Backlash)
    nl = make("sensor_nonlinearity", SensorNL)
    gain = bl = None
    if "gain_drift" in eff:
        form, s = eff["gain_drift"]
        gain = (Drift(form["components"], seed, "gain_drift"), s * form["size"] * 0.012)
    if "baseline_drift" in eff:
        form, s = eff["baseline_drift"]
        bl = (Drift(form["components"], seed, "baseline_drift"), s * form["size"] * 0.01 * dev.swing)

    temp_dyn = lag is not None or after is not None
    frac = np.concatenate([[0.0], np.logspace(-3.0, 0.0, 15)])
    u_rest = device.output(-dev.S, 0.0)   # the beam at rest: 0 V, insulating film
    if back is not None:
        back.u = u_rest
    if "creep" in eff:
        creep_rest = u_rest if eff["creep"][0]["driver"] == "deflection" else -dev.S
        creep = Creep(eff["creep"][0], eff["creep"][1], dev, creep_rest)
    k = dev.k

    out = []
    session_start = 0.0
    prev_end = None
    for r, sched in enumerate(schedules):
        v_arr = np.asarray(sched["v_V"], dtype=float)
        dwell = np.asarray(sched["dwell_s"], dtype=float)
        K = int(sched.get("readings", 10))
        n = len(v_arr)
        t_set, t_read, gap = timing(seed, r, dwell, K)
        if r > 0:
            session_start = prev_end + gap
            if lag is not None:
                lag.advance(0.0, gap)
        t_sess = session_start + t_read
        dT = amb.run(r, t_sess, session_start) if amb is not None else None
        h = device.hysteresis()
        if acc is not None:
            acc.tracker.reset()
        if fp is not None:
            fp.reset()
        x_cur = device.v_min_V
        phase = None
        v_prev = 0.0
        u_prev_clean = u_rest
        direction, t_change = 1, 0.0
        u_out = np.empty(n)
        fp_sensor = np.zeros(n)

        for i in range(n):
            v = float(v_arr[i])
            dwell_i = t_read[i] - t_set[i]
            if v != v_prev:
                direction = 1 if v > v_prev else -1
                t_change = t_set[i]
            # -- temperature: what the hysterons feel over the dwell, ending at the reading
            if temp_dyn:
                ts = dwell_i * frac
                if lag is not None:
                    R, Rth = lag.rise(v, ts)
                    Rth = Rth[-1]
                else:
                    R = np.full(len(ts), k * v * v)
                if dT is not None:
                    R = R + dT[i]
                xs = v + (device.equivalent_voltage(R) - device.equivalent_voltage(k * v * v))
                if after is not None:
                    xs = xs + after.offset(direction, t_set[i] - t_change + ts)
                targets = _turns(x_cur, xs)
                x_read = float(xs[-1])
            else:
                if dT is not None:
                    x_read = v + (float(device.equivalent_voltage(k * v * v + dT[i]))
                                  - float(device.equivalent_voltage(k * v * v)))
                else:
                    x_read = v
                targets = [x_read]
            # -- film
            for xt in targets:
                xh = inter.solve(h, xt, phase if phase is not None else h.value()) if inter is not None else xt
                phase = h.move(xh)
                if acc is not None:
                    acc.tracker.move(xh)
                x_cur = xt
            if phase is None:
                phase = h.value()
            ph = phase + acc.delta() if acc is not None else phase
            # -- deflection
            if lag is not None:
                vth = v + (Rth - k * v * v) / (k * dev.vmax)
            else:
                vth = v
            if joule is not None:
                vth = joule(vth)
            u = device.output(ph, vth)
            if rev is not None:
                u = u + rev(v, x_read)
            if creep is not None:
                creep.event(session_start + t_set[i], u if creep.form["driver"] == "deflection" else ph)
                u = u + creep.value(t_sess[i])
            if fp is not None:
                off = fp.step(v - v_prev, u - u_prev_clean)
                u_prev_clean = u
                if fp.form["origin"] == "mechanical":
                    u = u + off
                else:
                    fp_sensor[i] = off
            if back is not None:
                u = back(u)
            u_out[i] = u
            if lag is not None:
                lag.advance(v, t_set[i + 1] - t_set[i])
            v_prev = v

        # -- the heater goes off after the run
        t_end = t_set[n]
        prev_end = session_start + t_end
        if creep is not None:
            creep.event(prev_end, creep_rest)
        if back is not None:
            back(u_rest)

        # -- sensor
        y = u_out
        if nl is not None:
            y = nl(y)
        if gain is not None:
            y = y * np.exp(gain[1] * gain[0].run(r, t_sess, session_start))
        if bl is not None:
            y = y + bl[1] * bl[0].run(r, t_sess, session_start)
        if fp is not None:
            y = y + fp_sensor
        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * stream(seed, 1, r).standard_normal(n)
        rec = {
            "t_s": np.round(t_read / LOG_RESOLUTION_S) * LOG_RESOLUTION_S,
            "v_V": v_arr.copy(),
            "y_um": np.asarray(y, dtype=float),
            "dwell_s": np.round((t_read - t_set[:-1]) / LOG_RESOLUTION_S) * LOG_RESOLUTION_S,
        }
        out.append(rec)
    return out


def _turns(x_cur, xs):
    """The turning points of the input path ``x_cur -> xs[0] -> ... -> xs[-1]`` (what the Preisach needs)."""
    pts = [x_cur]
    d = 0
    for x in xs:
        x = float(x)
        nd = (x > pts[-1]) - (x < pts[-1])
        if nd == 0:
            continue
        if nd == d:
            pts[-1] = x
        else:
            pts.append(x)
            d = nd
    return pts[1:]
