"""The mechanisms, each as a small stateful object built from (form, strength, device, reference).

Units: V, K, um, s.  Sizes of strength 1 (about 1 % of the clean major loop's output swing):
see README.md.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.special import erf

from ._util import Reference, cell_thresholds, stream
from .processes import Path

K_B_EV = 8.617333262e-5
ONE_PCT = 0.01


def _norm_weights(form) -> tuple[np.ndarray, np.ndarray]:
    taus = np.asarray(form["taus_s"], dtype=float)
    w = np.asarray(form["weights"], dtype=float)
    return taus, w / np.sum(w)


# ============================================================================ temperature
class ThermalLag:
    """Slow thermal paths (substrate, package, surroundings) in parallel with the beam's fast response.

    Rise of the film ``r(t) = (1 - f) q_fast(t) + f sum_i w_i S_i(t)``; each slow path ``S_i`` relaxes
    to the steady rise ``q = kelvin_per_V2 v**2`` (power-driven) with its time constant (optionally
    longer when cooling, and shortened at high temperature by convection that grows with the
    temperature).  ``q_fast`` includes, optionally, the heater leads' TCR: the leads on the chip warm
    slowly, their resistance rises and the heater's power sags, so the film first overshoots.
    The steady state is always the base device's.
    """

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.taus, self.w = _norm_weights(form)
        res = float(form["residual_20s"])
        f1 = min(res / float(np.sum(self.w * np.exp(-20.0 / self.taus))), 0.5)
        self.f = float(-np.expm1(-s * f1))
        self.cool = float(form.get("cool_over_heat", 1.0))
        conv = form.get("convection")
        self.gamma, self.cexp = (float(conv["gamma"]), float(conv["exponent"])) if conv else (0.0, 1.0)
        tcr = form.get("lead_tcr")
        if tcr:
            self.tau_z = float(tcr["tau_s"])
            self.beta = s * float(tcr["ratio"]) * res / (50.0 * np.exp(-20.0 / self.tau_z))
        else:
            self.tau_z, self.beta = 1.0, 0.0
        self.rmax = ref.rise_max_K
        self.S = np.zeros_like(self.taus)
        self.z = 0.0

    def _tau(self, q: float) -> np.ndarray:
        tau = self.taus
        if self.gamma:
            tau = tau * (1.0 + self.gamma) / (1.0 + self.gamma * (max(q, 0.0) / self.rmax) ** self.cexp)
        return np.where(self.S > q, tau * self.cool, tau)

    def rise(self, q: float, t: np.ndarray) -> np.ndarray:
        """Film rise (K) at times ``t`` after the set-point change (heater held at rise ``q``)."""
        tau = self._tau(q)
        slow = (q + (self.S[None, :] - q) * np.exp(-t[:, None] / tau[None, :])) @ self.w
        fast = q
        if self.beta:
            zt = q + (self.z - q) * np.exp(-t / self.tau_z)
            fast = q * (1.0 + self.beta * q) / (1.0 + self.beta * zt)
        return (1.0 - self.f) * fast + self.f * slow

    def advance(self, q: float, dt: float) -> None:
        tau = self._tau(q)
        self.S = q + (self.S - q) * np.exp(-dt / tau)
        if self.beta:
            self.z = q + (self.z - q) * np.exp(-dt / self.tau_z)


class AmbientDrift:
    """The room / package temperature offset (K) of one run; unit 0.12 K at strength 1."""

    UNIT_K = 0.12

    def __init__(self, form: dict, s: float):
        self.form, self.scale = form, s * self.UNIT_K
        self.path = None

    def begin_run(self, seed: int, run: int, t_end: float) -> None:
        self.path = Path(self.form["components"], float(self.form.get("package_filter_s", 0.0)),
                         seed, run, "ambient_drift", t_end)

    def __call__(self, t):
        return self.scale * self.path(t)


# ============================================================================ film
class Interaction:
    """Mean-field stress coupling: hysterons feel ``x + sign * gamma * psi(phase / P)``."""

    def __init__(self, form: dict, s: float, ref: Reference):
        self.law = form["law"]
        self.kappa, self.a, self.b = float(form["kappa"]), float(form["a"]), float(form["b"])
        slope_psi = {"linear": 1.0, "saturating": 1.0, "asymmetric": 1.0 + abs(self.a),
                     "quadratic": 1.0 + abs(self.b)}[self.law]
        P, smax = ref.phase_half_um, max(ref.slope_max_um_per_V, 1e-9)
        g1 = 2.0 * ONE_PCT * ref.swing_um / smax              # V: moves the steepest point by 2 % swing
        gmax = 0.35 * P / (smax * slope_psi)                  # V: loop gain at most 0.35
        self.gamma = float(form["sign"]) * gmax * float(np.tanh(s * g1 / gmax))
        self.P = P

    def psi(self, p: float) -> float:
        if self.law == "linear":
            return p
        if self.law == "saturating":
            return float(np.tanh(self.kappa * p) / self.kappa)
        if self.law == "asymmetric":
            return p * (1.0 + self.a) if p > 0 else p * (1.0 - self.a)
        return p + 0.5 * self.b * (p * p - 1.0)

    def shift(self, phase: float) -> float:
        return self.gamma * self.psi(phase / self.P)


class Accommodation:
    """Weights of the phase transition change with the film's cycles ``N`` (from session start).

    ``density(N) = density * (1 + a(N) m)``: ``m`` a pattern over the Preisach cells (uniform for
    fatigue / training; the loop's width or the thresholds' centre for narrowing / shift),
    ``a(N) = 0.6 tanh(s delta a1 g(N) / 0.6)``, ``g`` a law of the cycles normalised to 1 at
    100 cycles (about one identification run), ``a1`` 0.02 (uniform) or 0.05 (a pattern).
    """

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.P = ref.phase_half_um
        self.law, self.N0, self.p = form["law"], float(form["N0"]), float(form["p"])
        self.N_pre = float(form["N_pre"])
        mode = form["mode"]
        a1 = 0.02 if mode in ("fatigue", "training") else 0.05
        self.k = s * float(form["delta"]) * a1 / 0.6
        g_ref = self._raw(100.0)
        self.g_norm = 1.0 / g_ref if g_ref > 0 else 1.0
        self.uniform = None
        if mode in ("fatigue", "training"):
            self.uniform = -1.0 if mode == "fatigue" else 1.0
            self.mask = None
        else:
            up, dn = cell_thresholds(device)
            d = device.density_um
            sig = d > 1e-4 * np.max(d)

            def pattern(name):
                x = (up - dn) if name in ("narrowing", "widening") else 0.5 * (up + dn)
                x = x - np.sum(d * x) / np.sum(d)
                x = x / max(np.max(np.abs(x[sig])), 1e-12)
                sgn = -1.0 if name in ("narrowing", "shift_low") else 1.0
                return np.clip(sgn * x, -1.0, 1.0)

            if mode == "mixed":
                mix = float(form["mix"])
                self.mask = np.clip(-mix + (1.0 - mix) * pattern(form["second"]), -1.0, 1.0)
            else:
                self.mask = pattern(mode)
        self.device = dataclasses.replace(device, density_um=device.density_um * self.mask) if self.mask is not None else None
        self.N = 0.0

    def _raw(self, N: float) -> float:
        a, b = self.N_pre, self.N_pre + N
        if self.law == "exp":
            return float(np.exp(-a / self.N0) - np.exp(-b / self.N0))
        if self.law == "log":
            return float(np.log((b + self.N0) / (a + self.N0)))
        return float((b / self.N0) ** self.p - (a / self.N0) ** self.p)

    def a(self) -> float:
        return 0.6 * float(np.tanh(self.k * self.g_norm * self._raw(self.N)))

    def count(self, dphase: float) -> None:
        self.N += abs(dphase) / (4.0 * self.P)


class Film:
    """The hysterons (base Preisach model) with the film-level mechanisms: interaction, accommodation."""

    def __init__(self, device, interaction: Interaction | None, accommodation: Accommodation | None):
        self.device, self.inter, self.acc = device, interaction, accommodation

    def begin_run(self) -> None:
        self.h = self.device.hysteresis()  # every run starts in negative saturation
        self.hm = self.acc.device.hysteresis() if (self.acc and self.acc.device is not None) else None
        self.phi = self.h.value()
        self.phm = self.hm.value() if self.hm else 0.0
        self.x_last = self.device.v_min_V

    def phase(self) -> float:
        if self.acc is None:
            return self.phi
        a = self.acc.a()
        if self.hm is None:
            return self.phi * (1.0 + a * self.acc.uniform)
        return self.phi + a * self.phm

    def _peek(self, z: float) -> float:
        ph = self.h.peek(z)
        if self.acc is None:
            return ph
        a = self.acc.a()
        if self.hm is None:
            return ph * (1.0 + a * self.acc.uniform)
        return ph + a * self.hm.peek(z)

    def _solve(self, x: float) -> float:
        """The self-consistent input ``z = x + shift(phase(z))`` from the current memory.

        ``phase(z)`` (peeked from the current memory) is non-decreasing in ``z`` and the loop gain is
        below one: the map is a contraction, iterated to its floating-point fixed point (so that the
        same input from the same memory gives bit-identical turning points and the Preisach memory
        does not fill with rounding-level corners)."""
        z = x + self.inter.shift(self.phase())
        for _ in range(400):
            z_new = x + self.inter.shift(self._peek(z))
            if abs(z_new - z) < 1e-12:
                return z_new
            z = z_new
        return z

    def move(self, x: float) -> None:
        z = self._solve(x) if self.inter is not None else x
        before = self.phi
        self.phi = self.h.move(z)
        if self.hm is not None:
            self.phm = self.hm.move(z)
        if self.acc is not None:
            self.acc.count(self.phi - before)
        self.x_last = x

    def follow(self, xs) -> None:
        """Let the hysterons follow the inputs ``xs`` (in time order) from the last one: only the
        turning points and the last value matter to a Preisach memory."""
        seq = [self.x_last]
        for x in xs:
            if x != seq[-1]:
                seq.append(float(x))
        if len(seq) == 1:
            self.move(float(xs[-1]))
            return
        for i in range(1, len(seq)):
            if i == len(seq) - 1 or (seq[i] - seq[i - 1]) * (seq[i + 1] - seq[i]) < 0:
                self.move(seq[i])


# ============================================================================ deflection
class JoulePower:
    """The bimorph term follows the heater power (the rise), with a temperature-dependent expansion.

    Thermal term ``c (v_th + m (H(r) - v_th))``, ``H(r) = v_max h(r / r_max)``, ``h`` the normalised
    integral of the expansion-coefficient mismatch over the rise; ``m = s * m1``, ``m1`` making the
    largest change 1 % of the swing at strength 1 (``m = 1``: fully power-driven).
    """

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.law = form["alpha_law"]
        self.a, self.b, self.kappa, self.p = (float(form[k]) for k in ("a", "b", "kappa", "p"))
        self.vmax, self.rmax = device.v_max_V, ref.rise_max_K
        v = np.linspace(device.v_min_V, device.v_max_V, 241)
        dev = np.abs(device.thermal_um_per_V * (self.H(device.rise_K(v)) - v))
        self.m = s * ONE_PCT * ref.swing_um / max(float(np.max(dev)), 1e-12)

    def h(self, z):
        if self.law == "constant_alpha":
            return z
        if self.law == "linear_alpha":
            return (z + 0.5 * self.a * z**2) / (1.0 + 0.5 * self.a)
        if self.law == "quadratic_alpha":
            return (z + 0.5 * self.a * z**2 + self.b * z**3 / 3.0) / (1.0 + 0.5 * self.a + self.b / 3.0)
        if self.law == "saturating":
            return np.expm1(-self.kappa * z) / np.expm1(-self.kappa)
        return np.power(z, self.p)

    def H(self, r):
        return self.vmax * self.h(np.maximum(r, 0.0) / self.rmax)

    def thermal_input(self, v_th: float, r: float) -> float:
        return v_th + self.m * (float(self.H(r)) - v_th)


class Reversible:
    """An anhysteretic, single-valued contribution of the input (or of the temperature)."""

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.form = form
        self.vmax, self.rmax = device.v_max_V, ref.rise_max_K
        self.zc = float(form["centre_frac"]) * self.vmax
        self.w = float(form["width_V"])
        v = np.linspace(device.v_min_V, device.v_max_V, 241)
        z = v if form["input"] == "voltage" else v**2 / self.vmax
        f = self.f(z)
        A = np.vstack([np.ones_like(v), v]).T
        self.coef = np.linalg.lstsq(A, f, rcond=None)[0]
        resid = f - A @ self.coef
        norm = float(np.max(np.abs(resid)))
        self.amp = float(form["sign"]) * s * ONE_PCT * ref.swing_um / max(norm, 1e-12)

    def f(self, z):
        shape, zz = self.form["shape"], np.asarray(z, dtype=float)
        if shape == "sigmoid":
            return np.tanh((zz - self.zc) / self.w)
        if shape == "bump":
            return np.exp(-(((zz - self.zc) / self.w) ** 2))
        if shape == "softplus":
            return self.w * np.logaddexp(0.0, (zz - self.zc) / self.w)
        u = np.maximum(zz, 0.0) / self.vmax
        if shape == "power":
            return u ** float(self.form["p"])
        a2, a3 = float(self.form["a2"]), float(self.form["a3"])
        if abs(a2) + abs(a3) < 0.1:
            a2 = 1.0
        return a2 * u**2 + a3 * u**3

    def __call__(self, v: float, r: float, dT: float, v_th: float) -> float:
        if self.form["input"] == "voltage":
            z, zl = v, v
        else:
            z, zl = self.vmax * max(r + dT, 0.0) / self.rmax, v_th
        return self.amp * (float(self.f(z)) - self.coef[0] - self.coef[1] * zl)


class Creep:
    """Visco-elastic relaxation of the beam and film after every change of the driving deflection.

    Driver ``D = a_p phase + a_t thermal_term`` through a level law ``G`` (Schapery-type
    nonlinearity: the creep of a change depends on its size and where it happens); states ``S_i``
    relax towards ``G(D)`` with retardation times ``tau_i`` (temperature-activated or
    stress-accelerated optionally); the reading is short of the relaxed deflection by
    ``sign W sum_i w_i (G(D) - S_i)``.  ``sign = -1``: stress relaxation, the reading overshoots.
    """

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.taus, self.w = _norm_weights(form)
        drv = form["driver"]
        self.a_p, self.a_t = float(drv["phase"]), float(drv["thermal"])
        self.c = device.thermal_um_per_V
        D_loop = self.a_p * ref.phase_loop_um + self.a_t * self.c * ref.v_loop_V
        self.Dr = max(float(np.ptp(D_loop)), 1e-9)
        lw = form["level_law"]
        self.law, self.la = lw["kind"], float(lw["a"])
        self.L = float(lw["l_frac"]) * self.Dr
        self.Dc = float(np.min(D_loop)) + float(lw["centre_frac"]) * self.Dr
        Gr = max(float(np.ptp(self.G(D_loop))), 1e-9)
        w1 = float(form["residual_20s"]) * ref.swing_um / (Gr * float(np.sum(self.w * np.exp(-20.0 / self.taus))))
        wmax = 0.6
        self.W = wmax * float(-np.expm1(-s * w1 / wmax))
        self.sign = float(form["sign"])
        rate = form["rate"]
        self.rate, self.E, self.kappa = rate["kind"], float(rate["E_eV"]), float(rate["kappa"])
        self.T_ref = 273.15 + device.ambient_C + 0.6 * ref.rise_max_K
        self.D_rest = self.a_p * (-ref.phase_half_um)
        self.S = np.full_like(self.taus, self.G(self.D_rest))

    def G(self, D):
        d = D - self.Dc
        if self.law == "quadratic":
            return D + self.la * d * np.abs(d) / self.Dr
        if self.law == "saturating":
            return self.Dc + self.L * np.tanh(d / self.L)
        return D

    def driver(self, phase: float, thermal_term: float) -> float:
        return self.a_p * phase + self.a_t * thermal_term

    def _tau(self, D: float, T_K: float) -> np.ndarray:
        if self.rate == "arrhenius":
            fac = float(np.clip(np.exp(self.E / K_B_EV * (1.0 / T_K - 1.0 / self.T_ref)), 1e-2, 1e2))
        elif self.rate == "eyring":
            fac = 1.0 / float(np.cosh(min(self.kappa * (D - self.Dc) / self.Dr, 20.0)))
        else:
            fac = 1.0
        return self.taus * fac

    def read(self, D: float, T_K: float, dt: float) -> float:
        g = float(self.G(D))
        St = g + (self.S - g) * np.exp(-dt / self._tau(D, T_K))
        return -self.sign * self.W * float(self.w @ (g - St))

    def advance(self, D: float, T_K: float, dt: float) -> None:
        g = float(self.G(D))
        self.S = g + (self.S - g) * np.exp(-dt / self._tau(D, T_K))


class FirstPoint:
    """An offset of the first reading(s) after the input reverses direction."""

    def __init__(self, form: dict, s: float, device, ref: Reference):
        self.form = form
        self.A = s * ONE_PCT * ref.swing_um
        self.vmax = device.v_max_V

    def begin_run(self, seed: int, run: int, n: int) -> None:
        rng = stream(seed, run, "first_point")
        self.jit = np.clip(1.0 + float(self.form["jitter"]) * rng.standard_normal(n), 0.2, 2.0)
        self.dir = 0.0
        self.events: list[tuple[int, float]] = []

    def _size(self, dv: float) -> float:
        law = self.form["size_law"]
        if law == "constant":
            return 1.0
        if law == "saturating":
            return float(-np.expm1(-dv / float(self.form["v0_V"])))
        if law == "power":
            return float((dv / self.vmax) ** float(self.form["p"]))
        return min(dv / self.vmax, 1.0)

    def _decay(self, k: int) -> float:
        rho = float(self.form["rho"])
        return rho**k if self.form["decay"] == "geometric" else (1.0 + k) ** (-1.0 / rho)

    def __call__(self, n: int, dv: float) -> float:
        if dv != 0.0:
            d = 1.0 if dv > 0 else -1.0
            if self.dir != 0.0 and d != self.dir:
                amp = float(self.form["amp_up"] if d > 0 else self.form["amp_down"])
                self.events.append((n, self.A * amp * self._size(abs(dv)) * float(self.jit[n])))
            self.dir = d
        linger = int(self.form["linger"])
        self.events = [(m, a) for (m, a) in self.events if n - m <= linger]
        return sum(a * self._decay(n - m) for (m, a) in self.events)


class Backlash:
    """Play in the optical lever's mount (one play, a distribution of plays, or an offset play)."""

    def __init__(self, form: dict, s: float, ref: Reference):
        r1 = s * 0.005 * ref.swing_um
        kind = form["kind"]
        if kind == "single":
            self.lo, self.hi, self.wt = np.array([r1]), np.array([r1]), np.array([1.0])
        elif kind == "distributed":
            rel = np.asarray(form["rel_widths"], dtype=float)
            wt = np.asarray(form["weights"], dtype=float)
            wt = wt / wt.sum()
            rel = rel / float(wt @ rel)
            self.lo, self.hi, self.wt = r1 * rel, r1 * rel, wt
        else:
            sp = float(form["split"])
            self.lo, self.hi, self.wt = np.array([2 * r1 * sp]), np.array([2 * r1 * (1 - sp)]), np.array([1.0])
        self.kappa = float(form["stiffness"])
        self.init_side = float(form["init_side"])
        self.z = None

    def start(self, u: float) -> None:
        if self.z is None:
            self.z = u + self.init_side * (self.hi if self.init_side > 0 else self.lo)
        else:
            self.apply(u)

    def apply(self, u: float) -> float:
        self.z = np.clip(self.z, u - self.lo, u + self.hi)
        return (1.0 - self.kappa) * float(self.wt @ self.z) + self.kappa * u


# ============================================================================ sensor
class InterferenceFringes:
    """Light spilling past the beam and reflected by the substrate interferes with the beam's
    reflection on the PSD: the spot's centroid is modulated periodically with the gap (period
    lambda / (2 xi) of tip deflection), with drifting optical phase (the laser diode's wavelength
    wanders with its temperature)."""

    def __init__(self, form: dict, s: float, ref: Reference):
        self.form = form
        self.A = s * 0.005 * ref.swing_um
        self.period = float(form["period_um"])
        self.F = float(form["finesse_F"])
        self.mid = 0.5 * (ref.u_min_um + ref.u_max_um)
        self.swing = ref.swing_um
        if self.F > 0:
            th = np.linspace(0, 2 * np.pi, 721)
            airy = 1.0 / (1.0 + self.F * np.sin(th / 2) ** 2)
            self.m, self.hr = float(np.mean(airy)), 0.5 * float(np.ptp(airy))
        self.path = None

    def begin_run(self, seed: int, run: int, t_end: float) -> None:
        self.path = Path(self.form["drift"], 0.0, seed, run, "interference_fringes", t_end)

    def __call__(self, u: float, t: float) -> float:
        theta = 2 * np.pi * u / self.period + float(self.form["phase0"]) + float(self.form["drift_rad"]) * float(self.path(t))
        if self.F > 0:
            phi = (1.0 / (1.0 + self.F * np.sin(theta / 2) ** 2) - self.m) / self.hr
        else:
            phi = np.cos(theta)
        vis = max(1.0 + float(self.form["visibility_slope"]) * (u - self.mid) / self.swing, 0.0)
        return self.A * vis * float(phi)


class SensorNonlinearity:
    """A smooth monotone map of the PSD around its (non-centred) electrical centre ``u0``."""

    def __init__(self, form: dict, s: float, ref: Reference):
        self.kernel = form["kernel"]
        half = 0.5 * (ref.u_max_um - ref.u_min_um)
        self.u0 = 0.5 * (ref.u_max_um + ref.u_min_um) + float(form["centre_frac"]) * half
        delta = 1.05 * max(ref.u_max_um - self.u0, self.u0 - ref.u_min_um)
        D1 = s * ONE_PCT * ref.swing_um
        k = self.kernel
        coef = {"tanh": 3.0, "erf": 3.0, "algebraic": 2.0, "sinh": 6.0}
        if k in coef:
            self.L = np.sqrt(delta**3 / (coef[k] * D1))
        elif k == "cubic":
            self.kappa = D1 / delta**3
        else:  # exp: convex or concave
            self.inv_L = float(form["sign"]) * 2.0 * D1 / delta**2
        self.ratio = float(form["side_ratio"])

    def __call__(self, u: float) -> float:
        d = u - self.u0
        k = self.kernel
        if k == "cubic":
            return u + self.kappa * d**3 * (self.ratio if d > 0 else 1.0 / self.ratio)
        if k == "exp":
            il = self.inv_L
            return self.u0 + (float(np.expm1(d * il)) / il if il != 0 else d)
        L = self.L * (np.sqrt(self.ratio) if d > 0 else 1.0 / np.sqrt(self.ratio))
        x = d / L
        if k == "tanh":
            return self.u0 + L * float(np.tanh(x))
        if k == "erf":
            return self.u0 + L * 0.5 * np.sqrt(np.pi) * float(erf(x))
        if k == "algebraic":
            return self.u0 + d / float(np.sqrt(1.0 + x * x))
        return self.u0 + L * float(np.sinh(x))


class GainDrift:
    """The PSD's sensitivity factor ``exp(0.01 s path(t))`` (a relative change of ~1 % at strength 1)."""

    def __init__(self, form: dict, s: float):
        self.form, self.k = form, s * ONE_PCT

    def begin_run(self, seed: int, run: int, t_end: float) -> None:
        self.path = Path(self.form["components"], 0.0, seed, run, "gain_drift", t_end)

    def __call__(self, t: float) -> float:
        return float(np.exp(self.k * float(self.path(t))))


class BaselineDrift:
    """The PSD's zero: an additive offset of size ~1 % of the swing at strength 1."""

    def __init__(self, form: dict, s: float, ref: Reference):
        self.form, self.k = form, s * ONE_PCT * ref.swing_um

    def begin_run(self, seed: int, run: int, t_end: float) -> None:
        self.path = Path(self.form["components"], 0.0, seed, run, "baseline_drift", t_end)

    def __call__(self, t: float) -> float:
        return self.k * float(self.path(t))
