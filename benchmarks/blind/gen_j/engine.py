"""Session simulator of generator J: the base device plus unmodelled mechanisms, in physical order.

Order of a reading (temperature -> film -> deflection -> beam -> mount -> sensor):

1. heater power -> beam temperature rise ``R(t)`` (``thermal_lag``), plus the room (``ambient_drift``);
2. the film's hysterons feel the equivalent voltage of ``R + dT_ambient`` (``interaction`` solved
   self-consistently, weights changing with use for ``accommodation``), moved through every turning
   point of the temperature during the dwell; the heater metallisation yields (``metal_plasticity``);
3. deflection ``u = bias + thermal * v + phase`` plus the lag of the bimorph term, ``joule_power``,
   ``reversible`` and the plastic curvature;
4. the beam relaxes (``creep``), the direction-reversal transient (``first_point``), the lever's
   mount (``backlash``);
5. the PSD: zero (``baseline_drift``), its nonlinearity (``sensor_nonlinearity``), its sensitivity
   (``gain_drift``), then noise.

With no mechanism (or every strength 0) each run is exactly ``base.clean_outputs``.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from scipy.optimize import brentq, nnls
from scipy.special import erf

from benchmarks.blind import base

from .drifts import drift_path, stream
from .forms import LIBRARY, OUTSIDE

# ------------------------------------------------------------------ strength units
# Strength 1 is about 1 % of the device's output swing (``U``) in the size of the gap it opens.
C_THERMAL = 2.0       # slow-path fraction: deviation ~ C * dT_unit at a 10 s dwell
C_CREEP = 0.018       # visible fraction of a full-swing change left at ~15 s
C_BASELINE = 1.0      # U per unit of the disturbance path
C_AMBIENT = 1.5       # dT_unit per unit of the disturbance path
C_JOULE = 1.5         # U at the worst point of the v**2-versus-v difference
C_SENSOR = 1.5        # U of residual after the lab's affine calibration over the working range
C_REVERSIBLE = 1.5    # U of the anhysteretic term's residual after an affine fit in v
C_INTERACTION = 0.03  # loop gain per unit strength (saturating below G_CAP)
G_CAP = 0.7
C_FIRST = 1.5         # U for a full-range reversing step
C_GAIN = 1.0          # relative sensitivity change: U / max|u| per unit of the path
C_BACKLASH = 1.0      # U of play half-width
C_ACCOM = 0.03        # relative weight change after 20 cycles of a grain
C_PLASTIC = 1.5       # U for the plastic strain's range over two full thermal cycles

_OFF_S = 600.0  # heater off between runs (about ten minutes), scaled per run by the timing stream
_PSD_RATE_HZ = 100.0


# ------------------------------------------------------------------ device calibration
class _Calibration:
    """Scales of one device, deterministic (the major loop of the clean device)."""

    def __init__(self, d: base.BaseDevice) -> None:
        try:  # a weak reference: the cache of calibrations must not keep devices alive
            self.d = weakref.proxy(d)
        except TypeError:
            self.d = d
        self.vmin, self.vmax = float(d.v_min_V), float(d.v_max_V)
        self.k = float(d.kelvin_per_V2)
        self.Rmax = float(d.rise_K(self.vmax))
        xs = np.linspace(self.vmin, self.vmax, 121)
        h = d.hysteresis()
        up = np.array([h.move(float(x)) for x in xs])
        dn = np.array([h.move(float(x)) for x in xs[::-1]])[::-1]
        th = float(d.thermal_um_per_V)
        u = np.concatenate([d.bias_um + th * xs + up, d.bias_um + th * xs + dn])
        self.u_lo, self.u_hi = float(u.min()), float(u.max())
        self.swing = max(self.u_hi - self.u_lo, 1e-9)
        self.U = 0.01 * self.swing
        self.u_abs = max(float(np.max(np.abs(u))), 1e-9)
        self.half = max(float(d.phase_swing_um), 1e-9)
        dx = np.diff(xs)
        self.slope_x = max(float(np.max(np.abs(np.diff(up)) / dx)), float(np.max(np.abs(np.diff(dn)) / dx)), 1e-9)
        dT = np.diff(np.asarray(d.rise_K(xs)))
        self.slope_T = max(float(np.max(np.abs(np.diff(up)) / dT)), float(np.max(np.abs(np.diff(dn)) / dT)), 1e-9)
        self.dT_unit = self.U / self.slope_T  # K that moves the steepest reading by ~1 % of the swing
        self.chord = th * self.vmax / self.Rmax  # um per K of the bimorph term (its average coefficient)
        self.T_mid = 0.5 * (float(d.transition_heating_C) + float(d.transition_cooling_C))
        self.ambient = float(d.ambient_C)
        self._cells = None

    def veq(self, rise):
        return np.sqrt(np.maximum(rise, 0.0) / self.k)

    def cells(self):
        """Switch-up and switch-down voltages of every Preisach cell (probed on the device)."""
        if self._cells is None:
            d = self.d
            h = d.hysteresis()
            nc = d.density_um.size
            alpha, beta = np.full(nc, np.nan), np.full(nc, np.nan)
            xs = np.linspace(self.vmin, self.vmax, 8 * d.levels + 1)
            for x in xs:
                h.move(float(x))
                sa = h._curve.signed_areas(h._grid)
                alpha[np.isnan(alpha) & (sa > 0)] = x
            for x in xs[::-1]:
                h.move(float(x))
                sa = h._curve.signed_areas(h._grid)
                beta[np.isnan(beta) & (sa < 0)] = x
            alpha = np.where(np.isnan(alpha), self.vmax, alpha)
            beta = np.where(np.isnan(beta), self.vmin, beta)
            self._cells = (alpha, beta)
        return self._cells


_CALIBRATIONS: "weakref.WeakKeyDictionary[base.BaseDevice, _Calibration]" = weakref.WeakKeyDictionary()


def _calibration(device: base.BaseDevice) -> _Calibration:
    """The device's scales, computed once per device object (a pure function of the device)."""
    try:
        return _CALIBRATIONS[device]
    except (KeyError, TypeError):
        pass
    cal = _Calibration(device)
    try:
        _CALIBRATIONS[device] = cal
    except TypeError:
        pass
    return cal


# ------------------------------------------------------------------ relaxation spectra
def spectrum_modes(spec: dict) -> tuple[np.ndarray, np.ndarray]:
    """Time constants (s) and weights (sum 1) of a relaxation spectrum form."""
    kind = spec["kind"]
    if kind == "discrete":
        taus, w = np.asarray(spec["taus_s"], float), np.asarray(spec["weights"], float)
    elif kind == "lognormal":
        c, s = float(spec["centre_s"]), float(spec["sigma_ln"])
        taus = np.geomspace(c * math.exp(-2.5 * s), c * math.exp(2.5 * s), 15)
        w = np.exp(-0.5 * (np.log(taus / c) / s) ** 2)
    elif kind == "power_law":
        taus = np.geomspace(float(spec["tmin_s"]), float(spec["tmax_s"]), 15)
        w = taus ** (-float(spec["beta"]))
    elif kind == "stretched":
        tau, b = float(spec["tau_s"]), float(spec["beta"])
        taus = np.geomspace(tau * 1e-3, tau * 1e2, 20)
        t = np.geomspace(tau * 1e-3, tau * 30.0, 120)
        w, _ = nnls(np.exp(-t[:, None] / taus[None, :]), np.exp(-((t / tau) ** b)))
        keep = w > 1e-6 * w.max()
        taus, w = taus[keep], w[keep]
    else:
        raise ValueError(f"unknown spectrum {kind!r}")
    return taus, w / w.sum()


# ------------------------------------------------------------------ the film
class _Film:
    """The hysterons, with the stress mean field (interaction) and use-dependent weights (accommodation)."""

    def __init__(self, cal: _Calibration, inter=None, accom=None) -> None:
        self.cal = cal
        self.h = cal.d.hysteresis()
        self.inter, self.accom = inter, accom
        self.w = cal.d.density_um
        self.p = self.h.value()
        self.x_last = cal.vmin
        if accom is not None:
            self.sa = self.h._curve.signed_areas(self.h._grid)
            self.counts = np.zeros(self.w.size)

    def reset_saturated(self) -> None:
        """The film back in negative saturation (weights and use counts kept)."""
        self.h = self.cal.d.hysteresis()
        self.x_last = self.cal.vmin
        if self.accom is not None:
            self.sa = self.h._curve.signed_areas(self.h._grid)
            self.p = float(self.w @ self.sa)
        else:
            self.p = self.h.value()

    def _peek(self, z: float) -> float:
        if self.accom is None:
            return self.h.peek(z)
        curve = self.h._curve.copy()
        curve.apply(float(self.h._grid.coordinates(np.array([float(z)]))[0]))
        return float(self.w @ curve.signed_areas(self.h._grid))

    def _solve(self, x: float) -> float:
        """The hysterons' input z = x + shift(phase(z)), with the loop gain below one (f increasing)."""
        it = self.inter
        f = lambda z: z - x - it.shift(self._peek(z))  # noqa: E731
        z0 = x + it.shift(self.p)
        f0 = f(z0)
        if abs(f0) < 1e-10:
            return z0
        z1 = z0 - f0  # one fixed-point step
        f1 = f(z1)
        for _ in range(12):  # secant
            if abs(f1) < 1e-10:
                return z1
            if f1 == f0:
                break
            z0, z1, f0 = z1, z1 - f1 * (z1 - z0) / (f1 - f0), f1
            f1 = f(z1)
        if abs(f1) < 1e-9:
            return z1
        b = it.bound + 1e-6
        return brentq(f, x - b, x + b, xtol=1e-11)

    def move(self, x: float) -> float:
        self.x_last = float(x)
        z = float(x) if self.inter is None else self._solve(float(x))
        p = self.h.move(z)
        if self.accom is not None:
            sa = self.h._curve.signed_areas(self.h._grid)
            self.counts += 0.25 * np.abs(sa - self.sa)  # a full switch and back is one cycle
            self.sa = sa
            self.w = self.accom.weights(self.counts)
            p = float(self.w @ sa)
        self.p = p
        return p


class _Interaction:
    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        law, a = form["law"], float(form["law_param"])
        ref = {"insulating": -1.0, "centre": 0.0, "metallic": 1.0}[form["reference"]]
        self.ref = ref * cal.half
        self.half = cal.half
        qmax = 2.0 if ref != 0.0 else 1.0
        if law == "linear":
            self.phi, dmax, bmax = (lambda q: q), 1.0, qmax
        elif law == "saturating":
            self.phi, dmax, bmax = (lambda q: math.tanh(a * q) / a), 1.0, math.tanh(a * qmax) / a
        else:  # superlinear: the stress grows faster once the metallic fraction percolates
            self.phi = lambda q: q * (1.0 + a * abs(q)) / (1.0 + 2.0 * a)
            dmax, bmax = (1.0 + 2.0 * a * qmax) / (1.0 + 2.0 * a), qmax * (1.0 + a * qmax) / (1.0 + 2.0 * a)
        g_raw = s * C_INTERACTION
        g = G_CAP * g_raw / (G_CAP + g_raw)  # loop gain, < G_CAP for every strength
        self.kappa = int(form["sign"]) * g / (dmax * cal.slope_x / cal.half)  # V per unit of phi
        self.bound = abs(self.kappa) * bmax * 1.05

    def shift(self, phase: float) -> float:
        return self.kappa * self.phi((phase - self.ref) / self.half)


class _Accommodation:
    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        law, c0, p = form["law"], float(form["c0"]), float(form["p"])
        if law == "log":
            self.G = lambda c: np.log1p(c / c0) / math.log1p(20.0 / c0)
        elif law == "power":
            self.G = lambda c: (np.maximum(c, 0.0) / 20.0) ** p
        else:
            self.G = lambda c: (1.0 - np.exp(-c / c0)) / (1.0 - math.exp(-20.0 / c0))
        self.prior = float(form["prior_cycles"])
        G0 = float(self.G(self.prior))
        # the change over the next 20 cycles from the film's prior use sets the unit (a long-trained
        # film still changes, only more slowly in absolute terms)
        unit = float(self.G(self.prior + 20.0)) - G0
        G_raw = self.G
        self.G = lambda c: (G_raw(c) - G0) / unit
        self.G0 = 0.0
        self.dens = cal.d.density_um
        self.pattern = form["pattern"]
        alpha, beta = cal.cells()
        eta = float(form["eta"])
        if self.pattern == "grain_size":  # small grains: wide hysteresis; they fatigue (or train) differently
            wid = alpha - beta
            self.pat = np.exp(eta * (wid - wid.mean()) / (wid.std() + 1e-12))
        elif self.pattern == "hot_grains":  # grains switching at high temperature (near the heater)
            self.pat = np.exp(eta * (alpha - alpha.mean()) / (alpha.std() + 1e-12))
        else:
            self.pat = np.ones(self.dens.size)
        self.amp = s * C_ACCOM * (-1.0 if form["direction"] == "fatigue" else 1.0)
        if self.pattern == "tc_shift":  # oxygen vacancies from cycling move the transition along the diagonal
            step = (cal.vmax - cal.vmin) / cal.d.levels
            q = 8.0 / step
            ia = np.rint((alpha - cal.vmin) * q).astype(int)
            ib = np.rint((beta - cal.vmin) * q).astype(int)
            index = {(a, b): i for i, (a, b) in enumerate(zip(ia, ib))}
            sh = 8 * int(form["shift_sign"])
            src = np.array([index.get((a + sh, b + sh), -1) for a, b in zip(ia, ib)])
            self.shifted = np.where(src >= 0, self.dens[np.maximum(src, 0)], 0.0)
            self.mass = self.dens.sum()
            self.rate = s * C_ACCOM * 1.5

    def weights(self, counts: np.ndarray) -> np.ndarray:
        if self.pattern == "tc_shift":
            cbar = float(self.dens @ counts) / self.mass
            m = 1.0 - math.exp(-self.rate * float(self.G(self.prior + cbar) - self.G0))
            return self.dens * (1.0 - m) + m * self.shifted
        return self.dens * np.exp(self.amp * (self.G(self.prior + counts) - self.G0) * self.pat)


# ------------------------------------------------------------------ temperature
class _Thermal:
    """Fast beam + slow heat paths into substrate/package (+ optional lead-resistance power sag)."""

    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.cal = cal
        self.taus, w = spectrum_modes(form["spectrum"])
        vis = float(np.sum(w * np.exp(-10.0 / self.taus)))
        a1 = C_THERMAL * cal.dT_unit / (0.3 * cal.Rmax * max(vis, 0.05))
        self.a_tot = 1.0 - math.exp(-s * a1)
        self.a = self.a_tot * w
        self.gamma = float(form["conductance_T"])
        self.beta = 2.0 * self.a_tot * float(form["tcr_rel"]) if form.get("tcr") else 0.0
        self.tau_tcr = float(form["tcr_tau_s"])
        self.S = np.zeros(self.taus.size)
        self.pkg = 0.0

    def advance(self, v: float, ts: np.ndarray) -> np.ndarray:
        """Rise (K) at times ``ts`` (s, increasing) after the heater is set to ``v``; state moves to ``ts[-1]``."""
        target = float(self.cal.d.rise_K(v))
        r = target / self.cal.Rmax
        tau = self.taus / (1.0 + self.gamma * r)
        E = np.exp(-ts[:, None] / tau[None, :])
        St = target + (self.S[None, :] - target) * E
        R = target * (1.0 - self.a_tot) + St @ self.a
        self.S = St[-1].copy()
        if self.beta > 0.0:
            pk = r + (self.pkg - r) * np.exp(-ts / self.tau_tcr)
            R = R * (1.0 + self.beta * r) / (1.0 + self.beta * pk)
            self.pkg = float(pk[-1])
        return R


# ------------------------------------------------------------------ deflection terms
class _Joule:
    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        law = form["alpha_law"]
        rr = np.linspace(0.0, 1.6, 1601)
        if law == "constant":
            S = rr
        elif law == "linear":
            S = rr + float(form["b"]) * rr ** 2 / 2.0
        elif law == "saturating":
            rs = float(form["r_s"])
            S = rs * np.log1p(rr / rs)
        elif law == "activated":
            ra = float(form["r_a"])
            S = ra * np.expm1(rr / ra)
        else:
            alpha = 1.0 + (float(form["ratio"]) - 1.0) / (1.0 + np.exp(-(rr - float(form["r_k"])) / float(form["width"])))
            S = np.concatenate([[0.0], np.cumsum(0.5 * (alpha[1:] + alpha[:-1]) * np.diff(rr))])
        self.rr, self.S = rr, S / np.interp(1.0, rr, S)
        self.cal = cal
        xs = np.linspace(cal.vmin, cal.vmax, 601)
        D = self._raw(xs)
        norm = float(np.max(np.abs(D)))
        self.amp = s * cal.U * C_JOULE / norm if norm > 0 else 0.0

    def _raw(self, x):
        cal = self.cal
        th = float(cal.d.thermal_um_per_V)
        r = cal.k * np.square(x) / cal.Rmax
        return th * cal.vmax * np.interp(r, self.rr, self.S) - th * x

    def __call__(self, x: float) -> float:
        return self.amp * float(self._raw(x))


class _Reversible:
    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.form, self.cal = form, cal
        xs = np.linspace(cal.vmin, cal.vmax, 601)
        f = self._f(xs)
        A = np.vstack([np.ones_like(xs), xs]).T
        (self.a0, self.a1), *_ = np.linalg.lstsq(A, f, rcond=None)
        norm = float(np.max(np.abs(f - self.a0 - self.a1 * xs)))
        self.amp = s * cal.U * C_REVERSIBLE * int(form["sign"]) / norm if norm > 0 else 0.0

    def _f(self, x):
        form, cal = self.form, self.cal
        rise = cal.k * np.square(x)
        T = cal.ambient + rise
        r = rise / cal.Rmax
        kind = form["kind"]
        if kind == "precursor_sigmoid":
            return np.tanh((T - cal.T_mid - float(form["offset_K"])) / float(form["width_K"]))
        if kind == "bump":
            return np.exp(-0.5 * ((T - cal.T_mid - float(form["offset_K"])) / float(form["width_K"])) ** 2)
        if kind == "polynomial":
            xi = 2.0 * x / cal.vmax - 1.0 if form["variable"] == "voltage" else 2.0 * r - 1.0
            c = form["coefficients"]
            p2 = 0.5 * (3 * xi ** 2 - 1)
            p3 = 0.5 * (5 * xi ** 3 - 3 * xi)
            p4 = (35 * xi ** 4 - 30 * xi ** 2 + 3) / 8.0
            return c[0] * p2 + c[1] * p3 + c[2] * p4
        if kind == "arrhenius":
            return np.exp(np.minimum((rise - cal.Rmax) / float(form["scale_K"]), 5.0))
        if kind == "saturating":
            return -np.expm1(-r / float(form["r0"]))
        raise ValueError(kind)

    def __call__(self, x: float) -> float:
        return self.amp * (float(self._f(np.float64(x))) - self.a0 - self.a1 * x)


class _Plastic:
    """Elastic-plastic stress of the heater metallisation (Flinn-type thermal cycling), T-dependent yield."""

    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.Y0, self.rho = float(form["yield_rt"]), float(form["softening"])
        self.law, self.m = form["yield_law"], float(form["m"])
        self.sig0 = float(form["residual"]) * self.Y0
        self.H = float(form["hardening"])
        self.eps, self.theta = 0.0, 0.0
        eps = []
        for th in [1.0, 0.0, 1.0, 0.0]:
            self.update(th)
            eps.append(self.eps)
        rng_ = max(max(eps + [0.0]) - min(eps + [0.0]), 1e-6)
        self.eps, self.theta = 0.0, 0.0
        self.scale = s * cal.U * C_PLASTIC * int(form["sign"]) / rng_

    def _Y(self, th: float) -> float:
        th = max(th, 0.0)
        if self.law == "power":
            return self.Y0 * max(1.0 - (1.0 - self.rho) * min(th, 1.5) ** self.m, 0.05)
        return self.Y0 * self.rho ** th

    def update(self, theta: float) -> None:
        start = self.theta
        n = max(2, int(abs(theta - start) / 0.05) + 1)
        for th in np.linspace(start, theta, n)[1:]:
            f = self.sig0 - th - (1.0 + self.H) * self.eps  # stress minus back stress
            Y = self._Y(float(th))
            if f > Y:
                self.eps += (f - Y) / (1.0 + self.H)
            elif f < -Y:
                self.eps += (f + Y) / (1.0 + self.H)
        self.theta = float(theta)

    def value(self) -> float:
        return self.scale * self.eps


# ------------------------------------------------------------------ beam and mount
class _Creep:
    """Anelastic relaxation of the beam: a standard-linear-solid bank with a nonlinear relaxed shape.

    Every mode's state relaxes towards ``g(drive)`` with its own time constant (longer or shorter when
    it grows than when it shrinks); the reading is short of (sign +1) or beyond (sign -1) the new shape
    by ``sum_i w_i (g(drive) - z_i)``.  Bounded by the range of ``g`` times the weights: no ratchet.
    """

    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.taus, w = spectrum_modes(form["spectrum"])
        vis = float(np.sum(w * np.exp(-15.0 / self.taus) * -np.expm1(-3600.0 / self.taus)))
        k1 = min(C_CREEP / max(vis, 0.05), 0.08)
        self.w = s * k1 * w
        self.sign = int(form["sign"])
        self.law = form["target_law"]
        self.curv = float(form["curvature"])
        self.sat = float(form["sat_scale"]) * cal.swing
        asym = float(form["asymmetry"])
        self.tau_up, self.tau_dn = self.taus * (1.0 + asym), self.taus * (1.0 - asym)
        self.mix = {"output": 1.0, "phase": 0.0}.get(form["source"], float(form["mix"]))
        self.S = cal.swing
        self.d0 = None
        self.z = np.zeros(self.taus.size)
        self.target = 0.0
        self.t_last = 0.0

    def drive_of(self, u: float, phase: float) -> float:
        return phase + self.mix * (u - phase)

    def _g(self, drive: float) -> float:
        x = drive - self.d0
        if self.law == "quadratic":
            return x + self.curv * x * x / self.S
        if self.law == "saturating":
            return self.sat * math.tanh(x / self.sat)
        return x

    def _z_at(self, t: float) -> np.ndarray:
        dt = t - self.t_last
        tau = np.where(self.target > self.z, self.tau_up, self.tau_dn)
        return self.target + (self.z - self.target) * np.exp(-dt / tau)

    def change(self, t: float, drive: float) -> None:
        if self.d0 is None:  # the relaxed state before the session
            self.d0 = drive
            self.target = self._g(drive)
            self.z[:] = self.target
            self.t_last = t
            return
        self.z = self._z_at(t)
        self.t_last = t
        self.target = self._g(drive)

    def offset(self, t: float) -> float:
        return self.sign * float(self.w @ (self.target - self._z_at(t)))


class _FirstPoint:
    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.amp = s * cal.U * C_FIRST
        self.A = {1: float(form["amp_up"]), -1: float(form["amp_down"])}
        self.law, self.sc = form["size_law"], float(form["size_scale_V"])
        self.linger, self.decay = int(form["linger"]), float(form["decay"])
        self.vmax = cal.vmax - cal.vmin
        self.prev_dir, self.v_prev, self.k, self.cur = -1, 0.0, None, 0.0

    def _size(self, step: float) -> float:
        x = step / self.vmax
        if self.law == "constant":
            return 1.0
        if self.law == "linear":
            return x
        if self.law == "sqrt":
            return math.sqrt(x)
        if self.law == "saturating":
            return -math.expm1(-step / self.sc) / -math.expm1(-self.vmax / self.sc)
        th = min(self.sc, 0.5 * self.vmax)  # threshold: a smooth onset above a step of ``sc`` volts
        return 1.0 / (1.0 + math.exp(-(step - th) / (0.2 * th)))

    def step(self, v: float) -> float:
        d = int(np.sign(v - self.v_prev))
        if d != 0 and d != self.prev_dir:
            self.cur = self.A[d] * self._size(abs(v - self.v_prev))
            self.k = 0
        if d != 0:
            self.prev_dir = d
        self.v_prev = v
        off = 0.0
        if self.k is not None and self.k < self.linger:
            off = self.amp * self.cur * self.decay ** self.k
            self.k += 1
        return off

    def heater_off(self) -> None:
        if self.v_prev > 0.0:
            self.prev_dir = -1
        self.v_prev, self.k = 0.0, None


class _Backlash:
    def __init__(self, form: dict, s: float, cal: _Calibration, y0: float) -> None:
        r = s * cal.U * C_BACKLASH
        self.kind = form["kind"]
        if self.kind == "distributed":
            radii = np.asarray(form["radii"], float)
            self.radii = r * radii / np.mean(radii)
            self.wts = np.asarray(form["weights"], float)
        else:
            self.radii, self.wts = np.array([r]), np.array([1.0])
        self.c = float(form.get("coupling", 1.0))
        self.dyn = float(form.get("dynamic_ratio", 1.0))
        self.m = y0 + self.radii  # at rest after cooling: engaged from above

    def step(self, y: float) -> float:
        for j, r in enumerate(self.radii):
            rd = r * self.dyn if self.kind == "stick_slip" else r
            if y > self.m[j] + r:
                self.m[j] = y - rd
            elif y < self.m[j] - r:
                self.m[j] = y + rd
        out = float(self.wts @ self.m)
        if self.kind == "partial":
            out = y + self.c * (out - y)
        return out


# ------------------------------------------------------------------ sensor
class _Sensor:
    """Lateral-effect PSD read off-centre, calibrated by the lab (affine fit) over the working range."""

    def __init__(self, form: dict, s: float, cal: _Calibration) -> None:
        self.shape = form["shape"]
        self.w = 0.5 * (cal.u_hi - cal.u_lo)
        self.uc = 0.5 * (cal.u_hi + cal.u_lo) + float(form["centre"]) * self.w
        order = 1 if self.shape in ("exp_bow", "rational") else 2
        self.bow = int(form["bow_sign"]) if self.shape == "exp_bow" else 1
        self.ugrid = np.linspace(cal.u_lo, cal.u_hi, 201)
        a_ref = 0.02
        dev_ref = self._residual(a_ref)
        target = C_SENSOR * cal.U
        a1 = a_ref * (target / dev_ref) ** (1.0 / order) if dev_ref > 0 else 0.0
        self.a = self.bow * a1 * s ** (1.0 / order)
        self.A, self.B = self._fit(self.a)

    def _phi(self, z, a):
        if a == 0.0:
            return z
        if self.shape == "tanh":
            return np.tanh(a * z) / a
        if self.shape == "erf":
            return erf(a * z) * math.sqrt(math.pi) / (2.0 * a)
        if self.shape == "sinh":
            return np.sinh(a * z) / a
        if self.shape == "exp_bow":
            return np.expm1(a * z) / a
        return z / np.sqrt(1.0 + a * z * z)

    def _raw(self, u, a):
        return self.uc + self.w * self._phi((u - self.uc) / self.w, a)

    def _fit(self, a):
        P = self._raw(self.ugrid, a)
        A, B = np.polyfit(self.ugrid, P, 1)
        return float(A), float(B)

    def _residual(self, a):
        A, B = self._fit(a)
        return float(np.max(np.abs((self._raw(self.ugrid, a) - B) / A - self.ugrid)))

    def __call__(self, u: float) -> float:
        return (float(self._raw(np.float64(u), self.a)) - self.B) / self.A


# ------------------------------------------------------------------ helpers
def _turning(seq, start: float) -> list[float]:
    """The local extrema of a sampled path (after ``start``) and its last point: all a Preisach film needs."""
    out, prev, direction = [], float(start), 0
    for x in seq:
        x = float(x)
        d = (x > prev) - (x < prev)
        if d != 0 and direction != 0 and d != direction:
            out.append(prev)
        if d != 0:
            direction = d
        prev = x
    out.append(prev)
    return out


class _Timing:
    """The logger's clock for one run (its own stream: independent of effects and of later runs)."""

    def __init__(self, seed: int, run: int, dwell: np.ndarray, K: int) -> None:
        rng = stream(seed, 0, run)
        n = dwell.size
        self.burst = min(max(K, 1) / _PSD_RATE_HZ, 0.8)
        overshoot = rng.uniform(0.0, 0.02, n)  # the host's sleep overshoots the requested dwell
        latency = 0.02 + rng.exponential(0.03, n)  # writing the log line, sending the next set-point
        self.gap = _OFF_S * float(rng.uniform(0.9, 1.25))
        act = dwell + overshoot
        period = act + self.burst + latency
        self.t_change = np.concatenate([[0.0], np.cumsum(period)[:-1]])
        self.t_read = self.t_change + act + 0.5 * self.burst
        self.t_next = self.t_change + period
        self.end = float(self.t_next[-1]) if n else 0.0


def _parse(effects) -> dict:
    known = LIBRARY + OUTSIDE
    active = {}
    for item in effects:
        family, form, strength = item
        if family not in known:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not math.isfinite(s) or s < 0.0:
            raise ValueError(f"strength of {family} must be finite and >= 0, got {strength!r}")
        if family in active:
            raise ValueError(f"mechanism {family} given twice")
        if s > 0.0:
            active[family] = (form, s)
    return active


# ------------------------------------------------------------------ the session
def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see ``SPEC.md``); returns one dict per run with t_s, v_V, y_um and dwell_s.

    ``dwell_s`` is what this lab's logger writes: the measured time from the set-point change to the
    (middle of the) PSD burst.  ``t_s`` is the time of that burst's middle since the run's first set-point.
    """
    seed = int(seed)
    cal = _calibration(device)
    act = _parse(effects)
    d = device

    def get(name, cls, *extra):
        return cls(act[name][0], act[name][1], cal, *extra) if name in act else None

    thermal = get("thermal_lag", _Thermal)
    inter = get("interaction", _Interaction)
    accom = get("accommodation", _Accommodation)
    joule = get("joule_power", _Joule)
    rev = get("reversible", _Reversible)
    plastic = get("metal_plasticity", _Plastic)
    creep = get("creep", _Creep)
    fp = get("first_point", _FirstPoint)
    sensor = get("sensor_nonlinearity", _Sensor)
    amb = act.get("ambient_drift")
    bas = act.get("baseline_drift")
    gain = act.get("gain_drift")
    film = _Film(cal, inter, accom)
    dynamic_input = thermal is not None or amb is not None

    def deflection(v, phase, R, x):
        u = d.output(phase, v)
        if thermal is not None:
            u += cal.chord * (R - float(d.rise_K(v)))
        if joule is not None:
            u += joule(float(cal.veq(R)) if thermal is not None else v)
        if rev is not None:
            u += rev(x)
        if plastic is not None:
            u += plastic.value()
        return u

    def pass_film(xs, thetas):
        for xp in _turning(xs, film.x_last):
            film.move(xp)
        if plastic is not None:
            for th in thetas:
                plastic.update(float(th))

    # the device at rest before the session: heater off for a long time, film in negative saturation
    u_rest = deflection(0.0, film.p, 0.0, 0.0)
    if creep is not None:
        creep.change(0.0, creep.drive_of(u_rest, film.p))
    mount = get("backlash", _Backlash, u_rest)

    outputs = []
    prev_end = 0.0  # session time at which the previous run ended
    run_start = 0.0
    for r, sch in enumerate(schedules):
        v_all = np.asarray(sch["v_V"], dtype=float)
        dwell = np.asarray(sch["dwell_s"], dtype=float)
        K = int(sch.get("readings", 1))
        tm = _Timing(seed, r, dwell, K)
        n = v_all.size

        if r > 0:  # heater off between the runs
            run_start = prev_end + tm.gap
            if thermal is not None:
                ts = np.geomspace(0.3, tm.gap, 12)
                R = thermal.advance(0.0, ts)
            else:
                R = np.zeros(1)
            pass_film(cal.veq(R), R / cal.Rmax)
            if float(cal.veq(R[-1])) <= cal.vmin:
                film.reset_saturated()  # everything below the lowest threshold: memory wiped
            u_gap = deflection(0.0, film.p, float(R[-1]), float(cal.veq(R[-1])))
            y_gap = u_gap
            if creep is not None:
                creep.change(prev_end, creep.drive_of(u_gap, film.p))
                y_gap = u_gap - creep.offset(run_start)
            if fp is not None:
                fp.heater_off()
            if mount is not None:
                mount.step(y_gap)

        # this run's disturbance paths (own streams)
        paths = {}
        for name, item in (("ambient_drift", amb), ("baseline_drift", bas), ("gain_drift", gain)):
            if item is not None:
                paths[name] = drift_path(item[0], name, seed, r, tm.end, run_start)
        amb_scale = amb[1] * cal.dT_unit * C_AMBIENT if amb is not None else 0.0

        def ambient(t):
            g, p = paths["ambient_drift"]
            return amb_scale * np.interp(t, g, p)

        y_out = np.empty(n)
        for i in range(n):
            v = float(v_all[i])
            tc = float(tm.t_change[i])
            d_read = float(tm.t_read[i] - tc)
            d_tail = float(tm.t_next[i] - tc)
            if dynamic_input:
                if thermal is not None:
                    ts = np.concatenate([np.geomspace(0.3, d_read, 8) if d_read > 0.3 else [d_read], [d_tail]])
                    R = thermal.advance(v, ts)
                else:
                    ts = np.array([0.0, d_read, d_tail])
                    R = np.full(3, float(d.rise_K(v)))
                Tr = R + ambient(tc + ts) if amb is not None else R
                xs = cal.veq(Tr)
                pass_film(xs[:-1], Tr[:-1] / cal.Rmax)
                R_read, x_read = float(R[-2]), float(xs[-2])
            else:
                film.move(v)
                if plastic is not None:
                    plastic.update(float(d.rise_K(v)) / cal.Rmax)
                R_read, x_read = float(d.rise_K(v)), v
            phase = film.p
            u = deflection(v, phase, R_read, x_read)
            y = u
            if creep is not None:
                creep.change(run_start + tc, creep.drive_of(u, phase))
                y = u - creep.offset(run_start + float(tm.t_read[i]))
            if fp is not None:
                y += fp.step(v)
            if mount is not None:
                y = mount.step(y)
            t_read = float(tm.t_read[i])
            if bas is not None:
                g, p = paths["baseline_drift"]
                y += bas[1] * cal.U * C_BASELINE * float(np.interp(t_read, g, p))
            if sensor is not None:
                y = sensor(y)
            if gain is not None:
                g, p = paths["gain_drift"]
                y *= math.exp(gain[1] * C_GAIN * cal.U / cal.u_abs * float(np.interp(t_read, g, p)))
            y_out[i] = y
            if dynamic_input:  # the short tail (burst + latency) before the next set-point
                film.move(float(xs[-1]))
                if plastic is not None:
                    plastic.update(float(Tr[-1]) / cal.Rmax)

        if noise_um is not None and float(noise_um) > 0.0:
            y_out = y_out + float(noise_um) * stream(seed, 3, r).normal(size=n)
        outputs.append({
            "t_s": np.round(tm.t_read, 3),
            "v_V": v_all.copy(),
            "y_um": y_out,
            "dwell_s": np.round(tm.t_read - tm.t_change, 3),
        })
        prev_end = run_start + tm.end
    return outputs


__all__ = ["simulate"]
