"""The mechanisms, one class each, in the rig's physical order.

temperature (ambient_drift, thermal_lag) -> film (interaction, accommodation)
-> deflection (joule_power, reversible, creep) -> optical lever mount (backlash)
-> optics (phase_reflectance) -> PSD (sensor_nonlinearity, gain_drift,
baseline_drift) -> first_point transient -> noise.

Every class takes ``(form, strength, ctx)``; ``strength > 0`` (absent
mechanisms are not built at all, so strength 0 is the clean device bit for bit).
Sizes are scaled so that strength 1 is about 1 % of the device's output swing
(the ``*_1`` constants; measured by ``measure.py``).
"""

from __future__ import annotations

import numpy as np

from .paths import DriftPath

# ---- strength-1 scales (calibrated with measure.py; see README) --------------------------
THERMAL_A1 = 0.006        # fraction of the power step still pending at a 20 s reading
THERMAL_TCR1 = 4.0e-5     # 1/K: heater-power change per kelvin of the slow temperature
AMBIENT_K1 = 0.15         # K: scale of the room's drift
JOULE_1 = 0.01            # max deviation of the thermal term, fraction of the swing
REVERSIBLE_1 = 0.012      # peak of the anhysteretic term, fraction of the swing
INTERACTION_G1 = 0.05     # loop gain of the mean field
CREEP_B1 = 0.015          # fraction of an output change still to come at a 20 s reading
BACKLASH_B1 = 0.025       # play, fraction of the swing
REFLECT_E1 = 0.025        # leak at the far end of the range, fraction of the swing
NONLIN_K1 = 0.015         # PSD error at the far end of the range, fraction of the swing
GAIN_G1 = 0.012           # relative sensitivity wander
BASELINE_D1 = 0.008       # zero wander, fraction of the swing
FIRST_F1 = 0.015          # first-point offset, fraction of the swing
ACCOM_A1 = 0.05           # relative weight change at full accommodation


def _sat(x: float, cap: float) -> float:
    """Monotone saturating map, ~x for small x, < cap always."""
    return float(cap * np.tanh(x / cap))


def spectrum(form: dict, n_cont: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Relaxation times (s) and weights (sum 1) of a kernel/spectrum form."""
    key = form.get("kernel", form.get("spectrum"))
    if key in ("exp_sum", "prony"):
        taus = np.asarray(form["taus_s"], float)
        w = np.asarray(form["weights"], float)
    elif key == "lognormal":
        z = np.linspace(-2.0, 2.0, 9)
        taus = form["tau_c_s"] * np.exp(form["sigma_ln"] * z)
        w = np.exp(-0.5 * z * z)
    else:  # diffusive, power_spectrum, log_uniform, power_law: weights ~ tau^-b per log-interval
        taus = np.geomspace(form["tau_lo_s"], form["tau_hi_s"], n_cont)
        w = taus ** (-float(form.get("exponent", 0.0)))
    return taus, w / w.sum()


# =========================================================================== temperature
class Thermal:
    """Slow thermal paths of the heater's power (V^2), exact for piecewise-constant drive.

    rise(t) = k [ (1 - a) P f_tcr(t) + a sum_i w_i L_i(t) ],   dL_i/dt = (P - L_i) / tau_i(direction)
    f_tcr = (1 + alpha k P) / (1 + alpha k L_tcr): the heater's resistance follows a slow temperature
    (with a series current-limit resistor the power rises or falls with it).  Steady state: k P.
    """

    def __init__(self, form: dict, strength: float, k: float, v_max: float):
        self.k = k
        self.taus, self.w = spectrum(form)
        pend = float(np.sum(self.w * np.exp(-20.0 / self.taus)))
        self.a = _sat(strength * THERMAL_A1 / max(pend, 0.02), 0.6)
        self.ratio = float(form.get("cooling_ratio", 1.0))
        self.alpha = 0.0
        if form.get("tcr"):
            alpha = strength * THERMAL_TCR1 * form["tcr_share"]
            self.alpha = form["tcr_sign"] * _sat(alpha * k * v_max**2, 0.3) / (k * v_max**2)
        self.tau_tcr = float(form.get("tcr_tau_s", 60.0))
        self.L = np.zeros_like(self.taus)
        self.Lt = 0.0
        self.P = 0.0
        self.t = 0.0

    def _tau(self):
        return np.where(self.P >= self.L, self.taus, self.taus * self.ratio)

    def set_power(self, P: float, t: float) -> None:
        dt = t - self.t
        if dt > 0:
            self.L = self.P + (self.L - self.P) * np.exp(-dt / self._tau())
            self.Lt = self.P + (self.Lt - self.P) * np.exp(-dt / self.tau_tcr)
            self.t = t
        self.P = P

    def rise(self, ts: np.ndarray) -> np.ndarray:
        dt = np.maximum(np.asarray(ts, float) - self.t, 0.0)
        L = self.P + (self.L - self.P)[None, :] * np.exp(-dt[:, None] / self._tau()[None, :])
        fast = self.P
        if self.alpha:
            Lt = self.P + (self.Lt - self.P) * np.exp(-dt / self.tau_tcr)
            fast = self.P * (1.0 + self.alpha * self.k * self.P) / (1.0 + self.alpha * self.k * Lt)
        return self.k * ((1.0 - self.a) * fast + self.a * (L @ self.w))


class Ambient:
    """Room/package temperature drift (K) seen by the film; optional bimorph share of the deflection."""

    def __init__(self, form: dict, strength: float, device):
        self.form = form
        self.scale = strength * AMBIENT_K1
        share = float(form.get("bimorph_share", 0.0))
        # secant slope of the thermal term per kelvin of rise at 4 V
        self.um_per_K = share * device.thermal_um_per_V * 4.0 / (device.kelvin_per_V2 * 16.0)
        self.path = None

    def start_run(self, rng, t_end):
        self.path = DriftPath(self.form["path"], rng, t_end, smooth_s=self.form.get("film_lag_s", 0.0))

    def dT(self, t_local):
        return self.scale * self.path(t_local)


# =========================================================================== film
class Interaction:
    """Mean field: the hysterons feel x + lam * m(phase / swing), solved self-consistently."""

    def __init__(self, form: dict, strength: float, slope_max: float):
        law = form["law"]
        self.law = law
        self.c = float(form.get("saturation", 1.0))
        self.b = float(form.get("asymmetry", 0.0))
        mprime = {"linear": 1.0, "saturating": self.c / np.tanh(self.c),
                  "asymmetric": 1.0 + abs(self.b), "metallic_only": 0.5}[law]
        gain = _sat(strength * INTERACTION_G1, 0.6)
        self.lam = form["sign"] * gain / (mprime * max(slope_max, 1e-6))  # V

    def m(self, p: float) -> float:
        if self.law == "linear":
            return p
        if self.law == "saturating":
            return float(np.tanh(self.c * p) / np.tanh(self.c))
        if self.law == "asymmetric":
            return p + 0.5 * self.b * (p * p - 1.0)
        return 0.5 * (p + 1.0)


class Accommodation:
    """Training/fatigue: each cell's weight changes with the cycles its grains (or the film) went through."""

    def __init__(self, form: dict, strength: float, density: np.ndarray, cells: dict):
        self.form = form
        self.d0 = density
        pat = form["pattern"]
        # a redistribution of weight among grains shows less than a uniform change: give it more
        boost = 1.0 if pat == "uniform" else 3.0
        self.amp = form["sign"] * _sat(strength * ACCOM_A1 * boost, 0.5)
        if pat == "uniform":
            p = np.ones_like(density)
        elif pat == "narrowing":  # wide loops lose weight, narrow ones gain
            wdt = cells["width"]
            p = -(wdt - np.average(wdt, weights=density + 1e-12))
        elif pat == "shift":  # the transition moves along the input with use
            cen = cells["centre"]
            p = cen - np.average(cen, weights=density + 1e-12)
        else:  # patchy: grains age unevenly, smooth along the cell index
            g = np.random.default_rng(form["pattern_seed"]).standard_normal(density.size)
            p = np.convolve(g, np.ones(9) / 9.0, mode="same")
        if pat != "uniform":  # standardise over the film's actual grains, then bound to [-1, 1]
            wts = density + 1e-12
            p = p - np.average(p, weights=wts)
            sd = np.sqrt(np.average(p * p, weights=wts))
            p = np.clip(p / (2.0 * sd), -1.0, 1.0) if sd > 0 else np.ones_like(density)
        self.pattern = p
        self.full = cells["full"]  # |signed area| of a fully switched cell
        self.counts = np.zeros_like(density)
        self.n0 = float(form["n0_cycles"])

    def _f(self, n):
        law = self.form["law"]
        if law == "exp":
            return 1.0 - np.exp(-n / self.n0)
        if law == "log":
            return np.log1p(n / self.n0) / np.log1p(20.0 / self.n0)
        return n / (n + self.n0)

    def record(self, d_areas: np.ndarray) -> None:
        self.counts += np.abs(d_areas) / (2.0 * self.full)  # half-cycles of each cell

    def weights(self) -> np.ndarray:
        cycles = 0.5 * self.counts
        if self.form["counting"] == "global":
            cycles = np.full_like(cycles, np.average(cycles, weights=self.d0 + 1e-12))
        w = self.d0 * (1.0 + self.amp * self._f(cycles) * self.pattern)
        if self.form["conserve"] and self.form["pattern"] != "uniform":
            w = w * (self.d0.sum() / w.sum())
        return w


class Film:
    """The base device's Preisach film, with the optional mean field and accommodation."""

    def __init__(self, device, interaction: Interaction | None = None, accommodation: Accommodation | None = None):
        self.device = device
        self.inter = interaction
        self.acc = accommodation
        self.h = device.hysteresis()
        self._areas = None

    # private access to the base's memory curve: the phase with weights other than the device's
    def _areas_now(self):
        return self.h._curve.signed_areas(self.h._grid)

    def _areas_peek(self, x):
        c = self.h._curve.copy()
        c.apply(float(self.h._grid.coordinates(np.array([float(x)]))[0]))
        return c.signed_areas(self.h._grid)

    def weights(self):
        return self.acc.weights() if self.acc is not None else self.device.density_um

    def start_run(self):
        self.h = self.device.hysteresis()
        if self.acc is not None:
            self._areas = self._areas_now()

    def _solve(self, x):
        lam, w = self.inter.lam, self.weights()
        tot = float(w.sum())

        def F(y):
            return y - x - lam * self.inter.m(float(w @ self._areas_peek(y)) / tot)

        lo, hi = x - abs(lam) * 1.0001, x + abs(lam) * 1.0001
        flo, fhi = F(lo), F(hi)
        if flo >= 0:
            return lo
        if fhi <= 0:
            return hi
        side = 0
        for _ in range(80):
            y = (lo * fhi - hi * flo) / (fhi - flo)
            fy = F(y)
            if abs(fy) < 1e-12 or hi - lo < 1e-11:
                return y
            if fy < 0:
                lo, flo = y, fy
                if side == -1:
                    fhi *= 0.5
                side = -1
            else:
                hi, fhi = y, fy
                if side == 1:
                    flo *= 0.5
                side = 1
        return 0.5 * (lo + hi)

    def go(self, x: float) -> float:
        """Move the hysterons' input to ``x`` (V); return the phase part (um)."""
        if self.inter is not None:
            x = self._solve(x)
        if self.acc is None:
            return self.h.move(x)
        self.h.move(x)
        areas = self._areas_now()
        self.acc.record(areas - self._areas)
        self._areas = areas
        return float(self.acc.weights() @ areas)

    def phase_norm(self, phase: float) -> float:
        return phase / float(self.weights().sum())


def film_geometry(device) -> dict:
    """Switching thresholds of each cell, found by ramps through the base's own memory curve."""
    h = device.hysteresis()
    grid = h._grid
    a_neg = h._curve.signed_areas(grid)
    full = np.maximum(np.abs(a_neg), 1e-15)
    xs = np.linspace(device.v_min_V, device.v_max_V, 121)
    up = np.full(a_neg.size, device.v_max_V)
    seen = np.zeros(a_neg.size, bool)
    for x in xs:
        h.move(float(x))
        hit = (~seen) & (h._curve.signed_areas(grid) >= 0)
        up[hit], seen[hit] = x, True
    down = np.full(a_neg.size, device.v_min_V)
    seen[:] = False
    for x in xs[::-1]:
        h.move(float(x))
        hit = (~seen) & (h._curve.signed_areas(grid) <= 0)
        down[hit], seen[hit] = x, True
    return {"full": full, "width": up - down, "centre": 0.5 * (up + down)}


def phase_slope_max(device) -> float:
    """Largest slope (1/V) of the normalised phase along the major loop's branches."""
    xs = np.linspace(device.v_min_V, device.v_max_V, 121)
    h = device.hysteresis()
    s = device.phase_swing_um
    ups = np.array([h.move(float(x)) for x in xs]) / s
    downs = np.array([h.move(float(x)) for x in xs[::-1]]) / s
    dx = xs[1] - xs[0]
    return float(max(np.max(np.abs(np.diff(ups))), np.max(np.abs(np.diff(downs)))) / dx)


# =========================================================================== deflection
class Joule:
    """The bimorph term follows the temperature rise (~v^2), not v; CTE may depend on temperature."""

    def __init__(self, form: dict, strength: float, device, swing: float):
        self.form = form
        self.k = device.kelvin_per_V2
        self.va = form["anchor_frac"] * device.v_max_V
        vv = np.linspace(0.0, device.v_max_V, 241)
        dev = np.max(np.abs(self._h(vv) - vv))
        target = strength * JOULE_1 * swing / max(abs(device.thermal_um_per_V) * dev, 1e-9)
        self.blend = float(1.0 - np.exp(-target))

    def _q(self, v):
        law = self.form["law"]
        if law == "power":
            return np.abs(v) ** self.form["exponent"]
        q = np.square(v)
        if law == "tempco":
            q = q * (1.0 + 0.5 * self.form["cte_per_K"] * self.k * q)
        return q

    def _h(self, v):
        return self.va * self._q(v) / self._q(self.va)

    def __call__(self, v: float) -> float:
        return float(v + self.blend * (self._h(v) - v))


class Reversible:
    """An anhysteretic term: a smooth single-valued function of the temperature (or of v)."""

    def __init__(self, form: dict, strength: float, device, swing: float):
        self.form = form
        self.dev = device
        rr = device.rise_K(np.linspace(0.0, device.v_max_V, 241))
        g = self._shape(rr, 0.0) - self._shape(0.0, 0.0)
        self.norm = max(float(np.max(np.abs(g))), 1e-12)
        self.g0 = float(self._shape(0.0, 0.0))
        self.amp = form["sign"] * strength * REVERSIBLE_1 * swing

    def _shape(self, rise, dT):
        f, d = self.form, self.dev
        T = d.ambient_C + dT + np.asarray(rise, float)
        z = (T - f["centre_C"]) / f["width_K"]
        s = f["shape"]
        if s == "sigmoid_T":
            return np.tanh(z)
        if s == "bump_T":
            return np.exp(-z * z)
        if s == "softplus_T":
            return np.logaddexp(0.0, z)
        if s == "square_T":
            return np.square(np.asarray(rise, float) / d.rise_K(d.v_max_V))
        v = d.equivalent_voltage(rise)
        return (v / d.v_max_V) ** f["exponent"]

    def __call__(self, rise: float, dT: float) -> float:
        return float(self.amp * (self._shape(rise, dT) - self.g0) / self.norm)


class Creep:
    """Visco-elastic relaxation after each output change (Prony series, size/direction dependent)."""

    def __init__(self, form: dict, strength: float, swing: float):
        self.form = form
        self.swing = swing
        self.taus, self.w = spectrum(form, n_cont=10)
        pend = float(np.sum(self.w * np.exp(-20.0 / self.taus)))
        self.beta = _sat(strength * CREEP_B1 / max(pend, 0.05), 0.5)
        self.sign = form["sign"]
        self.S = np.zeros_like(self.taus)
        self.t = 0.0

    def _size(self, du):
        f, sw = self.form, self.swing
        law = f["size_law"]
        if law == "power":
            s = np.sign(du) * sw * np.abs(du / sw) ** f["size_exponent"]
        elif law == "saturating":
            c = f["size_scale"] * sw
            s = c * np.tanh(du / c)
        else:
            s = du
        return s * (f["up_factor"] if du > 0 else f["down_factor"])

    def event(self, t: float, du: float) -> None:
        if t > self.t:
            self.S = self.S * np.exp(-(t - self.t) / self.taus)
            self.t = t
        if du != 0.0:
            self.S = self.S + self.w * self.beta * self._size(du)

    def value(self, t: float) -> float:
        return float(self.sign * np.sum(self.S * np.exp(-max(t - self.t, 0.0) / self.taus)))


# =========================================================================== mount, optics, sensor
class Backlash:
    """Play in the optical lever's mount: the mount follows the beam only once the play is taken up."""

    def __init__(self, form: dict, strength: float, swing: float):
        b = strength * BACKLASH_B1 * swing
        n = int(form.get("plays", 1))
        frac = np.linspace(1.0 - form.get("spread", 0.0), 1.0, n) if n > 1 else np.ones(1)
        self.widths = b * frac / frac.mean()
        a = float(form.get("asymmetry", 0.0))
        self.lo = self.widths * (1.0 + a) / 2.0   # how far the mount may sit below the beam
        self.hi = self.widths * (1.0 - a) / 2.0   # ... and above it
        self.c = float(form.get("coupling", 1.0))
        self.initial = form.get("initial", "centred")
        self.m = None

    def rest(self, u: float) -> None:
        """The beam at rest (heater off): the first time, the mount as the form says; later it follows."""
        if self.m is None:
            if self.initial == "below":
                self.m = u - self.lo
            elif self.initial == "above":
                self.m = u + self.hi
            else:
                self.m = np.full_like(self.widths, u)
        else:
            self(u)

    def __call__(self, u: float) -> float:
        self.m = np.clip(self.m, u - self.lo, u + self.hi)
        return float(u + self.c * np.mean(self.m - u))


class Reflectance:
    """VO2's reflectance at the laser's wavelength changes with the metallic fraction; offsets in the
    sum and difference channels let the intensity leak through the sum/difference normalisation."""

    def __init__(self, form: dict, strength: float, lo: float, hi: float):
        swing = hi - lo
        self.rho = float(form["contrast"])
        self.c = 0.5 * (lo + hi) + form["centre_frac"] * swing / 2.0
        # offsets sized so that the leak is about REFLECT_E1 of the swing at strength 1
        lever = abs(self.rho) * max(abs(lo - self.c), abs(hi - self.c)) / swing
        scale = strength * REFLECT_E1 / max(lever, 0.05)
        self.s = scale * form["sum_share"]
        self.d = scale * (1.0 - form["sum_share"]) * form["diff_sign"] * swing

    def __call__(self, y: float, phase_norm: float) -> float:
        r = 1.0 + self.rho * 0.5 * (phase_norm + 1.0)
        return float(y + ((y - self.c) * self.s * (r - 1.0) + self.d * (1.0 - r)) / (r + self.s))


class SensorNL:
    """A lateral-effect PSD: smooth, monotone, linear only near its centre; the spot may be off-centre."""

    def __init__(self, form: dict, strength: float, lo: float, hi: float):
        swing = hi - lo
        self.shape = form["shape"]
        self.c = 0.5 * (lo + hi) + form["centre_frac"] * swing / 2.0
        self.L = form["half_length_frac"] * swing
        # the far end of the output range, in PSD half-lengths: size the curvature so that the
        # reading there is off by about NONLIN_K1 of the swing at strength 1
        zmax = max(abs(lo - self.c), abs(hi - self.c)) / self.L
        odd = strength * NONLIN_K1 * swing / (self.L * zmax**3)
        even = strength * NONLIN_K1 * swing / (self.L * zmax**2)
        if self.shape == "odd_even":
            e = form["even_share"]
            self.k_odd, self.k_even = odd * (1.0 - e), even * e * form["even_sign"]
        elif self.shape == "exp":
            self.k_odd, self.k_even = 0.0, even * form["even_sign"]
        else:
            self.k_odd, self.k_even = odd, 0.0

    def __call__(self, y: float) -> float:
        z = (y - self.c) / self.L
        if self.k_odd > 0:
            b = np.sqrt(3.0 * self.k_odd)
            if self.shape == "atan":
                z = np.arctan(b * z) / b
            elif self.shape == "algebraic":
                z = z / np.sqrt(1.0 + 2.0 * self.k_odd * z * z)
            else:
                z = np.tanh(b * z) / b
        if self.k_even != 0.0:
            b = 2.0 * self.k_even
            z = np.expm1(b * z) / b
        return float(self.c + self.L * z)


class Gain:
    """The PSD's sensitivity wanders: the reading about the sensor's zero times (1 + eps(t))."""

    def __init__(self, form: dict, strength: float, mid: float, swing: float):
        self.form = form
        self.scale = strength * GAIN_G1
        zf = form.get("zero_frac")
        self.z0 = 0.0 if zf is None else mid + zf * swing / 2.0
        self.path = None

    def start_run(self, rng, t_end):
        self.path = DriftPath(self.form["path"], rng, t_end)

    def __call__(self, y: float, t: float) -> float:
        return float(self.z0 + (y - self.z0) * (1.0 + self.scale * float(self.path(t))))


class Baseline:
    """The PSD's zero wanders: an additive offset (um)."""

    def __init__(self, form: dict, strength: float, swing: float):
        self.form = form
        self.scale = strength * BASELINE_D1 * swing
        self.path = None

    def start_run(self, rng, t_end):
        self.path = DriftPath(self.form["path"], rng, t_end)

    def __call__(self, y: float, t: float) -> float:
        return float(y + self.scale * float(self.path(t)))


class FirstPoint:
    """An offset on the first reading(s) after the input changes direction, by set-point count."""

    def __init__(self, form: dict, strength: float, swing: float):
        self.f = form
        self.amp = strength * FIRST_F1 * swing
        self.start_run()

    def start_run(self):
        self.last_dir = -1 if self.f["first_step_counts"] else 0
        self.since = 10**9
        self.rev_dir = 0
        self.size = 0.0
        self.prev_v = 0.0

    def _law(self, d):
        f = self.f
        law, s = f["size_law"], f["size_scale_V"]
        if law == "constant":
            return 1.0
        if law == "linear":
            return d / 4.0
        if law == "sqrt":
            return np.sqrt(d / 4.0)
        return (1.0 - np.exp(-d / s)) / (1.0 - np.exp(-2.0 / s))

    def __call__(self, v: float) -> float:
        dv = v - self.prev_v
        self.prev_v = v
        direc = int(np.sign(dv))
        if direc != 0 and self.last_dir != 0 and direc != self.last_dir:
            self.since, self.rev_dir, self.size = 0, direc, abs(dv)
        else:
            self.since += 1
        if direc != 0:
            self.last_dir = direc
        if self.since > self.f["linger"] or self.rev_dir == 0:
            return 0.0
        f = self.f
        pol = {"fixed": 1, "along": self.rev_dir, "against": -self.rev_dir}[f["polarity"]]
        side = f["up_factor"] if self.rev_dir > 0 else f["down_factor"]
        return float(self.amp * f["sign"] * pol * side * self._law(self.size) * f["decay"] ** self.since)
