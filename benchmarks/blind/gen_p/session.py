"""One session of the rig with unmodelled mechanisms, in their physical order.

temperature (heater aging, thermal lag, ambient drift)
  -> film (interaction, accommodation: the hysterons)
  -> deflection (joule power, reversible part, creep, first-point transient of the mechanics)
  -> optical-lever mount (backlash)
  -> sensor (nonlinearity, first-point transient of the sensor, gain drift, baseline drift)
  -> logger (noise, time stamps).
"""

from __future__ import annotations

import weakref

import numpy as np

from ..base import BaseDevice
from .forms import FAMILIES
from .paths import realise, stream

_KB_EV = 8.617333262e-5  # eV / K
_TEMPERATURE = ("thermal_lag", "ambient_drift", "heater_aging")
_DAMAGE_UNIT_S = 3600.0
_PSD_SAMPLE_S = 0.004     # one PSD reading; a burst of K readings, at most 0.4 s


# =========================================================================== device summary
class _Ctx:
    """What the mechanisms need to know of the device: swing, transition, steepest slope."""

    def __init__(self, device: BaseDevice) -> None:
        self.dev = device
        self.k = float(device.kelvin_per_V2)
        self.vmin, self.vmax = float(device.v_min_V), float(device.v_max_V)
        self.S = float(device.phase_swing_um)
        self.c = float(device.thermal_um_per_V)
        self.rise_max = self.k * self.vmax * self.vmax
        self.rise_mid = 0.5 * (device.transition_heating_C + device.transition_cooling_C) - device.ambient_C
        self.v_mid = float(device.equivalent_voltage(self.rise_mid))
        xs = np.linspace(self.vmin, self.vmax, 121)
        h = device.hysteresis()
        up = np.array([h.peek(x) for x in xs])
        h.move(self.vmax)
        down = np.array([h.peek(x) for x in xs])
        u = np.concatenate([device.bias_um + self.c * xs + up, device.bias_um + self.c * xs + down])
        self.u_lo, self.u_hi = float(u.min()), float(u.max())
        self.swing = self.u_hi - self.u_lo
        dx = xs[1] - xs[0]
        self.slope_max = float(max(np.max(np.abs(np.diff(up))), np.max(np.abs(np.diff(down)))) / dx)


_CTX_CACHE: "weakref.WeakKeyDictionary[BaseDevice, _Ctx]" = weakref.WeakKeyDictionary()


def _ctx(device: BaseDevice) -> _Ctx:
    """The device summary, computed once per (immutable) device."""
    try:
        return _CTX_CACHE[device]
    except (KeyError, TypeError):
        pass
    ctx = _Ctx(device)
    try:
        _CTX_CACHE[device] = ctx
    except TypeError:
        pass
    return ctx


def _sat(s: float, x0: float, cap: float) -> float:
    """``s * x0`` for small values, smoothly bounded by ``cap`` (monotone in ``s``)."""
    return cap * -np.expm1(-s * x0 / cap)


# =========================================================================== temperature
class _Lag:
    """Slow thermal paths (substrate, package, surroundings) in parallel with the fast beam."""

    def __init__(self, form: dict, s: float) -> None:
        self.taus = np.asarray(form["taus_s"], float)
        w = np.asarray(form["weights"], float)
        w = w / w.sum()
        probe = np.geomspace(8.0, 60.0, 5)
        s_ref = float(np.mean(np.exp(-probe[:, None] / self.taus[None, :]) @ w))
        f = _sat(s, form["f0"] / max(s_ref, 1e-3), 0.6)
        self.fw = f * w
        self.fast = 1.0 - f
        self.cool = float(form["cool_over_heat"])
        self.state = np.zeros_like(self.taus)

    def samples(self, power: float, offsets: np.ndarray) -> np.ndarray:
        """The heater's part of the film's rise (K) at ``offsets`` (s) after the set-point change."""
        tau = np.where(self.state <= power, self.taus, self.taus * self.cool)
        st = power + (self.state[None, :] - power) * np.exp(-offsets[:, None] / tau[None, :])
        return self.fast * power + st @ self.fw

    def monotone(self, power: float) -> bool:
        d = self.state - power
        return bool(np.all(d <= 0.0) or np.all(d >= 0.0))

    def advance(self, power: float, duration: float) -> None:
        tau = np.where(self.state <= power, self.taus, self.taus * self.cool)
        self.state = power + (self.state - power) * np.exp(-duration / tau)


class _Aging:
    """Heater metallization aging (electromigration / annealing), Black's law, cumulative over runs."""

    def __init__(self, form: dict, s: float, ctx: _Ctx, device: BaseDevice) -> None:
        self.f, self.s, self.ctx = form, s, ctx
        self.t0 = 273.15 + float(device.ambient_C)
        self.v_ref = ctx.vmax
        self.rate_ref = self._raw(self.v_ref)
        # P = V^2 R / (R + R_ext)^2: dlnP/dlnR = (rho - 1) / (rho + 1), rho = R_ext / R
        rho = float(form["series_ratio"])
        self.dlnp_dlnr = 1.0 if rho > 1.0 else -1.0

    def _raw(self, v: float) -> float:
        if v <= 0.0:
            return 0.0
        th = self.t0 + self.f["overheat"] * self.ctx.k * v * v
        return (v / self.ctx.vmax) ** self.f["n_current"] * np.exp(-self.f["Ea_eV"] / (_KB_EV * th))

    def rate_per_s(self, v: float) -> float:
        """Damage per second (1 = one hour at v_max)."""
        return self._raw(v) / self.rate_ref / _DAMAGE_UNIT_S

    def power_factor(self, damage: float) -> float:
        f = self.f
        if f["law"] == "em":
            F = damage ** f["m"]
        else:
            F = f["em_weight"] * damage - (-np.expm1(-damage / f["D0"]))
        # F > 0: the resistance has grown; the power changes by a0 * F (relative) at strength 1
        return float(np.exp(self.dlnp_dlnr * self.s * f["a0"] * F))


# =========================================================================== film
class _Film:
    """The hysterons: base population, accommodation's modified populations, mean-field interaction."""

    def __init__(self, ctx: _Ctx, inter, accom, n_cycles: float) -> None:
        self.ctx = ctx
        self.h0 = ctx.dev.hysteresis()
        self.pops: list = []         # (share, hysteresis or None, transform (a, b) or const)
        self.accom = accom
        self.N = n_cycles
        if accom is not None:
            form, s = accom
            self.A0, self.s_acc = float(form["A0"]), s
            scale = {"amplitude": 0.5, "shift": 1.0, "spread": 1.5}
            for c in form["components"]:
                if c["kind"] == "amplitude":
                    const = -ctx.S if c["stuck"] == "insulating" else 0.0
                    self.pops.append((c["share"] * scale["amplitude"], None, const))
                elif c["kind"] == "shift":
                    self.pops.append((c["share"] * scale["shift"], ctx.dev.hysteresis(), (1.0, c["delta_V"])))
                else:
                    lam = c["lam"]
                    self.pops.append((c["share"] * scale["spread"], ctx.dev.hysteresis(),
                                      (lam, ctx.v_mid * (1.0 - lam))))
            self.counter = form["counter"]
            self.m = form["m"]
            self.turn = self.ext = 0.0
            self.dirn = 0.0
        self.inter = inter
        if inter is not None:
            form, s = inter
            self.gain = _sat(s, form["gain0"], 0.7)
            self.alpha = form["sign"] * self.gain / ctx.slope_max
            self.pref = {"insulating": -ctx.S, "centre": 0.0, "metallic": ctx.S}[form["reference"]]
            self.slope = 1.0
        self.p0 = -ctx.S
        self.value = self._combine(self.p0, [None if h is None else -ctx.S for _, h, _ in self.pops])

    # ---------------------------------------------------------------- accommodation
    def _fN(self) -> float:
        f, N = self.accom[0], self.N
        if f["law"] == "exp":
            return -np.expm1(-N / f["N0"])
        if f["law"] == "log":
            return np.log1p(N / f["N0"]) / np.log1p(100.0 / f["N0"])
        return (N / 100.0) ** f["beta"]

    def _combine(self, p0: float, others: list) -> float:
        """Phase part: the base population plus the fractions moved to the modified ones."""
        if self.accom is None:
            return p0
        a = _sat(self.s_acc, self.A0 * self._fN(), 0.6)
        out, moved = 0.0, 0.0
        for (share, h, tr), val in zip(self.pops, others):
            out += a * share * (tr if h is None else val)
            moved += a * share
        return (1.0 - moved) * p0 + out

    def _count(self, x: float, p0_old: float, p0_new: float) -> None:
        if self.counter == "transformed":
            self.N += abs(p0_new - p0_old) / (4.0 * self.ctx.S)
            return
        r = self.ctx.k * x * x / self.ctx.rise_max
        if self.dirn == 0.0:
            if r != self.ext:
                self.dirn = 1.0 if r > self.ext else -1.0
                self.ext = r
            return
        if (r - self.ext) * self.dirn >= 0.0:
            self.ext = r
        else:
            self.N += 0.5 * abs(self.ext - self.turn) ** self.m
            self.turn, self.ext, self.dirn = self.ext, r, -self.dirn

    # ---------------------------------------------------------------- moves
    def _peek(self, z: float) -> float:
        others = [None if h is None else h.peek(tr[0] * z + tr[1]) for _, h, tr in self.pops]
        return self._combine(self.h0.peek(z), others)

    def _solve(self, x: float) -> float:
        """The input the hysterons feel: ``z = x + alpha (phase(z) - pref)``, solved on the current memory.

        ``g(z) = z - x - alpha (phase(z) - pref)`` increases with slope in ``[1 - gain, 1 + gain]``
        (the phase's slope never exceeds the major loop's), so the root is unique; a safeguarded
        secant (bisection inside a bracket when a step leaves it) finds it in a few evaluations.
        """
        a, pref, tol = self.alpha, self.pref, 1e-11
        g = lambda z: z - x - a * (self._peek(z) - pref)
        z0 = x + a * (self.value - pref)
        g0 = g(z0)
        if abs(g0) <= tol:
            return z0
        lo = hi = None
        if g0 < 0.0:
            lo = (z0, g0)
        else:
            hi = (z0, g0)
        z1 = z0 - g0 / self.slope
        for _ in range(60):
            g1 = g(z1)
            if abs(g1) <= tol:
                break
            if g1 < 0.0:
                lo = (z1, g1)
            else:
                hi = (z1, g1)
            if g1 != g0:
                sl = (g1 - g0) / (z1 - z0)
                if sl > 0.0:
                    self.slope = min(max(sl, 1.0 - self.gain), 1.0 + self.gain)
            z0, g0 = z1, g1
            z1 = z0 - g0 / self.slope
            if lo is not None and hi is not None and not (lo[0] < z1 < hi[0]):
                z1 = 0.5 * (lo[0] + hi[0])
        return z1

    def move(self, x: float) -> float:
        if self.inter is None and self.accom is None:
            self.value = self.h0.move(x)
            return self.value
        z = self._solve(x) if self.inter is not None else x
        self.z_last = z
        p0_old = self.p0
        self.p0 = self.h0.move(z)
        others = [None if h is None else h.move(tr[0] * z + tr[1]) for _, h, tr in self.pops]
        self.value = self._combine(self.p0, others)
        if self.accom is not None:
            self._count(x, p0_old, self.p0)
        return self.value


def _turning(xs: np.ndarray) -> np.ndarray:
    """The samples the hysterons must visit: the turning points of ``xs`` and its last value."""
    if len(xs) <= 2:
        return xs
    d = np.diff(xs)
    keep = [i + 1 for i in range(len(d) - 1) if d[i] * d[i + 1] < 0.0]
    return np.concatenate([xs[keep], xs[-1:]])


# =========================================================================== shapes
def _joule_phi(form: dict, r: float) -> float:
    sh = form["shape"]
    if sh == "power":
        return float(np.sign(r) * abs(r) ** form["q"])
    if sh == "cte_poly":
        g1, g2 = form["g1"], form["g2"]
        return (r + g1 * r * r / 2.0 + g2 * r ** 3 / 3.0) / (1.0 + g1 / 2.0 + g2 / 3.0)
    k, w, j = form["knee"], form["width"], form["jump"]
    sp = lambda y: np.logaddexp(0.0, y)
    F = lambda y: y + j * w * (sp((y - k) / w) - sp(-k / w))
    return float(F(r) / F(1.0))


class _Reversible:
    def __init__(self, form: dict, s: float, ctx: _Ctx) -> None:
        self.f, self.ctx = form, ctx
        grid = np.linspace(0.0, ctx.rise_max, 401)
        raw = self._raw(grid)
        self.r0 = float(self._raw(np.array([0.0]))[0])
        self.norm = float(np.max(np.abs(raw - self.r0)))
        self.amp = s * form["a0"] * ctx.swing * form["sign"]

    def _raw(self, rise: np.ndarray) -> np.ndarray:
        f, ctx = self.f, self.ctx
        xi = np.sqrt(np.maximum(rise, 0.0) / ctx.rise_max)
        if f["shape"] == "sigmoid":
            return np.tanh((rise - ctx.rise_mid - f["center_K"]) / f["width_K"])
        if f["shape"] == "bump":
            return np.exp(-0.5 * ((rise - ctx.rise_mid - f["center_K"]) / f["width_K"]) ** 2)
        if f["shape"] == "power":
            return xi ** f["p"]
        y = 2.0 * xi - 1.0
        return f["c2"] * 0.5 * (3.0 * y * y - 1.0) + f["c3"] * 0.5 * (5.0 * y ** 3 - 3.0 * y)

    def __call__(self, rise: float) -> float:
        return self.amp * (float(self._raw(np.array([rise]))[0]) - self.r0) / self.norm


def _sensor(form: dict, s: float, ctx: _Ctx, u: np.ndarray) -> np.ndarray:
    """The PSD's smooth monotone reading of the deflection ``u`` (um)."""
    u0 = form["center_frac"] * 0.5 * ctx.swing
    H = max(abs(ctx.u_hi - u0), abs(ctx.u_lo - u0))   # the far end of the range from the centre
    e = s * form["a0"]                       # relative deviation at |u - u0| = H (first order)
    z = u - u0
    sh = form["shape"]
    if sh == "tanh":                         # compressive, symmetric about the centre
        L = H / np.sqrt(3.0 * e)
        return u0 + L * np.tanh(z / L)
    if sh == "atan":                         # compressive (edge of a lateral-effect PSD)
        L = H / np.sqrt(3.0 * e)
        return u0 + L * np.arctan(z / L)
    if sh == "sinh":                         # expansive
        L = H / np.sqrt(6.0 * e)
        return u0 + L * np.sinh(z / L)
    if sh == "cubic":
        return u + e * z ** 3 / (H * H)
    L = H / (2.0 * e) * form["sign"]          # exp: a bow, either way
    return u0 + L * np.expm1(z / L)


# =========================================================================== one run
def _run(ctx: _Ctx, sch: dict, mech: dict, seed: int, run: int, noise_um, carry: dict) -> dict:
    dev = ctx.dev
    v = np.asarray(sch["v_V"], dtype=float)
    dwell = np.asarray(sch["dwell_s"], dtype=float)
    K = max(int(sch.get("readings", 1)), 1)
    n = len(v)

    # ---- logger timing (own stream): software latency, then a burst of K readings
    rt = stream(seed, run, "timing")
    latency = 0.04 + rt.gamma(2.0, 0.03, n)
    burst = K * min(_PSD_SAMPLE_S, 0.4 / K)
    t_c = np.concatenate(([0.0], np.cumsum(dwell + latency + burst)))
    t_r = t_c[:-1] + dwell + latency + 0.5 * burst
    z_noise = stream(seed, run, "noise").standard_normal(n)

    # ---- drift realisations (own streams), interpolated at any time
    drift = {}
    for fam in ("baseline_drift", "ambient_drift", "gain_drift"):
        if fam in mech:
            drift[fam] = realise(mech[fam][0], seed, run, fam, float(t_c[-1]))

    def at(fam, t):
        tg, up = drift[fam]
        return np.interp(t, tg, up)

    amb = mech.get("ambient_drift")
    lag = _Lag(*mech["thermal_lag"]) if "thermal_lag" in mech else None
    aging = _Aging(*mech["heater_aging"], ctx, dev) if "heater_aging" in mech else None
    temp_active = any(f in mech for f in _TEMPERATURE)
    joule = mech.get("joule_power")
    if joule is not None:
        jb = joule[1] * min(1.0, joule[0]["a0"] * ctx.swing / max(abs(ctx.c) * ctx.vmax / 4.0, 1e-12))
    rev = _Reversible(mech["reversible"][0], mech["reversible"][1], ctx) if "reversible" in mech else None
    film = _Film(ctx, mech.get("interaction"), mech.get("accommodation"), carry["N"])
    phase_init = film.value
    damage = carry["D"]

    u = np.empty(n)
    phase = np.empty(n)
    k = ctx.k
    for i in range(n):
        vi = float(v[i])
        p_clean = k * vi * vi
        tr_off = float(t_r[i] - t_c[i])
        full = float(t_c[i + 1] - t_c[i])
        if aging is not None:
            rate = aging.rate_per_s(vi)
            power = p_clean * aging.power_factor(damage + rate * tr_off)
            damage += rate * full
        else:
            power = p_clean
        if lag is not None:
            if lag.monotone(power):
                offs = np.array([tr_off])
            else:
                offs = tr_off * np.array([0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0])
            heat = lag.samples(power, offs)
            lag.advance(power, full)
        else:
            offs = np.array([tr_off])
            heat = np.array([power])
        d_amb = amb[1] * amb[0]["amp_K"] * at("ambient_drift", t_c[i] + offs) if amb is not None else 0.0
        if temp_active:
            xs = np.asarray(dev.equivalent_voltage(heat + d_amb), dtype=float)
            for x in _turning(xs):
                ph = film.move(float(x))
        else:
            ph = film.move(vi)
        phase[i] = ph
        # the thermal-expansion term
        heat_r = float(heat[-1])
        damb_r = float(d_amb[-1]) if amb is not None else 0.0
        if temp_active or joule is not None:
            t_th = heat_r + (damb_r if (amb is not None and amb[0]["bimorph"]) else 0.0)
            v_th = vi + (t_th - p_clean) / (k * ctx.vmax)
            if joule is not None:
                v_th = (1.0 - jb) * v_th + jb * ctx.vmax * _joule_phi(joule[0], t_th / ctx.rise_max)
        else:
            v_th = vi
        ui = dev.output(ph, v_th)
        if rev is not None:
            ui += rev(heat_r + damb_r if rev.f["input"] == "temperature" else p_clean)
        u[i] = ui
    carry["D"] = damage
    carry["N"] = film.N

    # ---- deflection: creep
    if "creep" in mech:
        u = u + _creep(mech["creep"][0], mech["creep"][1], ctx, u, phase, phase_init, t_c, t_r)
    # ---- first reading after a reversal
    fp = _first_point(mech["first_point"][0], mech["first_point"][1], ctx, v) if "first_point" in mech else None
    if fp is not None and mech["first_point"][0]["stage"] == "mechanics":
        u = u + fp
    # ---- optical-lever mount
    if "backlash" in mech:
        u = _backlash(mech["backlash"][0], mech["backlash"][1], ctx, u, dev.output(phase_init, 0.0))
    # ---- sensor
    y = u
    if "sensor_nonlinearity" in mech:
        y = _sensor(mech["sensor_nonlinearity"][0], mech["sensor_nonlinearity"][1], ctx, y)
    if fp is not None and mech["first_point"][0]["stage"] == "sensor":
        y = y + fp
    if "gain_drift" in mech:
        f, s = mech["gain_drift"]
        y = y * np.exp(s * f["a0"] * at("gain_drift", t_r))
    if "baseline_drift" in mech:
        f, s = mech["baseline_drift"]
        b = at("baseline_drift", t_r)
        if f["zeroed"]:
            b = b - at("baseline_drift", 0.0)
        y = y + s * f["a0"] * ctx.swing * b
    if noise_um is not None:
        y = y + float(noise_um) * z_noise
    return {"t_s": t_r, "v_V": v.copy(), "y_um": np.asarray(y, dtype=float), "dwell_s": t_r - t_c[:-1]}


# =========================================================================== output-side mechanisms
def _creep(form, s, ctx, u, phase, phase_init, t_c, t_r) -> np.ndarray:
    """Visco-elastic relaxation: parallel Kelvin-Voigt elements, each lagging the deflection.

    Element ``k`` relaxes towards the present deflection with time constant ``tau_k``; the reading
    is short of the relaxed shape by ``c * sum_k w_k g(d - z_k)`` where ``g`` sets how the delayed
    part depends on the size and the direction of the change.  No ratcheting: it vanishes at rest.
    """
    taus = np.asarray(form["taus_s"], float)
    w = np.asarray(form["weights"], float)
    w = w / w.sum()
    c = _sat(s, form["c0"], 0.5) * form["sign"]
    if form["driver"] == "phase":
        d, d0 = phase, phase_init
    else:
        d, d0 = u, ctx.dev.output(phase_init, 0.0)
    ref = 0.25 * ctx.swing
    p = form["power"] if form["law"] == "power" else 1.0

    def g(delta):
        amp = np.sign(delta) * np.power(np.abs(delta) / ref, p) * ref if p != 1.0 else delta
        return amp * np.where(delta > 0.0, form["up"], form["down"])

    out = np.empty(len(u))
    z = np.full(len(taus), float(d0))
    for i in range(len(u)):
        di = float(d[i])
        z_r = di + (z - di) * np.exp(-(t_r[i] - t_c[i]) / taus)
        out[i] = -c * float(w @ g(di - z_r))
        z = di + (z - di) * np.exp(-(t_c[i + 1] - t_c[i]) / taus)
    return out


def _first_point(form, s, ctx, v) -> np.ndarray:
    n = len(v)
    out = np.zeros(n)
    prev_dir = 0.0
    v_prev = 0.0                     # every run starts from 0 V held for a long time
    a = s * form["a0"] * ctx.swing
    span = ctx.vmax - ctx.vmin
    for i in range(n):
        dv = float(v[i]) - v_prev
        v_prev = float(v[i])
        if dv == 0.0:
            continue
        dirn = 1.0 if dv > 0.0 else -1.0
        if prev_dir != 0.0 and dirn != prev_dir:
            x = abs(dv) / span
            law = form["law"]
            if law == "constant":
                size = 1.0
            elif law == "linear":
                size = x / 0.5
            elif law == "sqrt":
                size = np.sqrt(x / 0.5)
            else:
                size = np.tanh(x / form["x0"]) / np.tanh(0.5 / form["x0"])
            size *= form["up"] if dirn > 0 else form["down"]
            pol = {"along": dirn, "against": -dirn, "fixed": form["sign"]}[form["polarity"]]
            o = a * size * pol
            out[i] += o
            for m in range(1, form["n_linger"] + 1):
                if i + m < n:
                    out[i + m] += o * form["rho"] ** m
        prev_dir = dirn
    return out


def _backlash(form, s, ctx, u, u_rest) -> np.ndarray:
    r = s * form["a0"] * ctx.swing
    if form["kind"] == "distributed":
        widths = np.asarray(form["widths"], float) * r
        weights = np.asarray(form["weights"], float)
    else:
        widths, weights = np.array([r]), np.array([1.0])
    out = np.zeros(len(u))
    for wdt, wgt in zip(widths, weights):
        m = u_rest + form["init"] * wdt
        track = np.empty(len(u))
        for i, ui in enumerate(u):
            m = min(max(m, ui - wdt), ui + wdt)
            track[i] = m
        out += wgt * track
    if form["kind"] == "elastic":
        out = out + form["kappa"] * (u - out)
    return out


# =========================================================================== session
def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see the package's docstring and README.md)."""
    mech: dict = {}
    for family, form, strength in effects:
        if family not in FAMILIES:
            raise ValueError(f"unknown mechanism {family!r}")
        strength = float(strength)
        if not np.isfinite(strength) or strength < 0.0:
            raise ValueError("strength must be >= 0")
        if family in mech:
            raise ValueError(f"mechanism {family!r} given twice")
        if strength > 0.0:
            mech[family] = (form, strength)
    ctx = _ctx(device)
    carry = {"N": 0.0, "D": 0.0}   # film cycles and heater damage carry over from run to run
    return [_run(ctx, sch, mech, int(seed), r, noise_um, carry) for r, sch in enumerate(schedules)]
