"""Generator C's session simulator: the base device plus phenomenological unmodelled mechanisms.

Physical order of the chain (every stage is skipped when none of its mechanisms is present,
so strength 0 reproduces ``base.clean_outputs`` bit for bit):

1. temperature: heater power -> beam (instant) + slow thermal paths (``thermal_lag``), room (``ambient_drift``)
2. film: hysterons (``interaction``: self-consistent mean field; ``accommodation``: weights change with use)
3. deflection: eq. (22) + ``joule_power`` + ``reversible`` + ``creep``
4. mechanics of the optical lever: ``backlash``, ``first_point`` (stage "mechanics")
5. sensor: ``sensor_nonlinearity`` -> ``thermochromic_gain`` -> ``gain_drift`` -> ``first_point`` (stage
   "sensor") -> ``baseline_drift`` -> noise

The lab's logger (see README.md): time stamps only, no ``dwell_s``.  Each set-point costs a fixed
``OVERHEAD_S`` (DAQ write + handshake + the heater driver's settling) before the dwell timer starts,
then the dwell, then a burst of ``K`` readings at ``READ_PERIOD_S``; the time stamp is the middle of
the burst, counted from the run's first set-point command.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from benchmarks.blind import base

from . import paths
from .forms import LIBRARY, OUTSIDE

#: Fixed per-set-point overhead (s) between the set-point command and the start of the dwell timer.
OVERHEAD_S = 0.35
#: Spacing (s) of the K readings of one burst.
READ_PERIOD_S = 0.01
#: Nominal time (s) with the heater off between two runs (each session draws 85-115 % of it).
OFF_S_NOMINAL = 600.0

_KNOWN = set(LIBRARY) | set(OUTSIDE)


# ---------------------------------------------------------------------------------------------
# device scales (cached)


@dataclass
class DeviceInfo:
    u_lo: float  # extremes of the clean major loop (um)
    u_hi: float
    swing: float  # output swing (um)
    phase_swing: float  # half the phase swing (um)
    slope_max: float  # steepest d phase / d x on the major loop (um/V)
    x_slope: float  # where (V)
    alpha: np.ndarray  # switching-up voltage of each cell (V)
    beta: np.ndarray  # switching-down voltage of each cell (V)
    x_mid: float  # equivalent voltage of the middle of the transition (V)
    r_max: float  # rise at v_max (K)


_INFO: "weakref.WeakKeyDictionary[base.BaseDevice, DeviceInfo]" = weakref.WeakKeyDictionary()


def _crossings(xs: np.ndarray, areas: np.ndarray, rising: bool) -> np.ndarray:
    """Where each cell's signed area crosses zero along a monotone sweep ``xs``."""
    a = areas if rising else -areas
    out = np.empty(a.shape[1])
    for k in range(a.shape[1]):
        idx = np.nonzero(a[:, k] > 0.0)[0]
        if idx.size == 0:
            out[k] = xs[-1]
            continue
        i = int(idx[0])
        if i == 0:
            out[k] = xs[0]
            continue
        a0, a1 = a[i - 1, k], a[i, k]
        out[k] = xs[i - 1] + (xs[i] - xs[i - 1]) * (0.0 - a0) / (a1 - a0)
    return out


def device_info(device: base.BaseDevice) -> DeviceInfo:
    try:
        return _INFO[device]
    except KeyError:
        pass
    xs = np.linspace(device.v_min_V, device.v_max_V, 121)
    h = device.hysteresis()
    p_up, a_up, p_dn, a_dn = [], [], [], []
    for x in xs:
        p_up.append(h.move(x))
        a_up.append(np.array(h._curve.signed_areas(h._grid), float))
    for x in xs[::-1]:
        p_dn.append(h.move(x))
        a_dn.append(np.array(h._curve.signed_areas(h._grid), float))
    p_up, p_dn = np.array(p_up), np.array(p_dn)[::-1]
    a_up, a_dn = np.array(a_up), np.array(a_dn)[::-1]
    u = np.concatenate([device.bias_um + device.thermal_um_per_V * xs + p_up,
                        device.bias_um + device.thermal_um_per_V * xs + p_dn])
    dx = np.diff(xs)
    slopes = np.concatenate([np.diff(p_up) / dx, np.diff(p_dn) / dx])
    mids = np.concatenate([0.5 * (xs[1:] + xs[:-1])] * 2)
    i = int(np.argmax(slopes))
    t_mid = 0.5 * (device.transition_heating_C + device.transition_cooling_C) - device.ambient_C
    info = DeviceInfo(
        u_lo=float(u.min()), u_hi=float(u.max()), swing=float(u.max() - u.min()),
        phase_swing=device.phase_swing_um, slope_max=float(max(slopes[i], 1e-9)), x_slope=float(mids[i]),
        alpha=_crossings(xs, a_up, True), beta=_crossings(xs[::-1], a_dn[::-1], False),
        x_mid=float(device.equivalent_voltage(t_mid)), r_max=float(device.rise_K(device.v_max_V)),
    )
    _INFO[device] = info
    return info


# ---------------------------------------------------------------------------------------------
# session plan


@dataclass
class Plan:
    v: np.ndarray  # set-point of every session step (V); pseudo steps (heater off between runs) included
    T: np.ndarray  # session time of the set-point change (s)
    R: np.ndarray  # session time of the reading (middle of the burst) (s)
    nxt: np.ndarray  # session time of the next change (s)
    run: np.ndarray  # run index (pseudo steps: -1)
    run_start: list[float]  # session time of each run's start
    run_end: list[float]  # session time of each run's last reading


def make_plan(schedules: list[dict], seed: int) -> Plan:
    rng = paths.stream(seed, "session")
    v, T, R, nxt, run = [], [], [], [], []
    starts, ends = [], []
    t = 0.0
    for r, sch in enumerate(schedules):
        if r > 0:  # heater off for about ten minutes
            off = OFF_S_NOMINAL * float(rng.uniform(0.85, 1.15))
            v.append(np.zeros(1)), T.append(np.array([t])), R.append(np.array([t + off]))
            nxt.append(np.array([t + off])), run.append(np.array([-1]))
            t += off
        vv = np.asarray(sch["v_V"], float)
        dw = np.asarray(sch["dwell_s"], float)
        burst = max(int(sch.get("readings", 1)), 1) * READ_PERIOD_S
        step = OVERHEAD_S + dw + burst
        tc = t + np.concatenate([[0.0], np.cumsum(step)[:-1]])
        starts.append(t)
        v.append(vv), T.append(tc), R.append(tc + OVERHEAD_S + dw + 0.5 * burst)
        nxt.append(tc + step), run.append(np.full(vv.size, r))
        t = float(tc[-1] + step[-1]) if vv.size else t
        ends.append(float(R[-1][-1]) if vv.size else t)
    cat = np.concatenate
    return Plan(cat(v), cat(T), cat(R), cat(nxt), cat(run), starts, ends)


# ---------------------------------------------------------------------------------------------
# helpers


def _sigmoid(z):
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(z, float)))


def _softplus(z):
    return np.logaddexp(0.0, z)


def _affine_residual_peak(z: np.ndarray, f: np.ndarray) -> float:
    A = np.vstack([np.ones_like(z), z]).T
    coef, *_ = np.linalg.lstsq(A, f, rcond=None)
    return float(np.max(np.abs(f - A @ coef)))


def _turning_points(cur: float, xs: list[float]) -> list[float]:
    """Only the turning points of the path cur -> xs[0] -> ... -> xs[-1] matter to a Preisach model."""
    out: list[float] = []
    prev = cur
    for i, x in enumerate(xs[:-1]):
        nxt = xs[i + 1]
        if (x - prev) * (nxt - x) < 0.0:
            out.append(x)
            prev = x
    out.append(xs[-1])
    return out


# ---------------------------------------------------------------------------------------------
# stage 1: temperature


def _temperature(device, plan: Plan, eff: dict, seed: int):
    """Per session step: the hysterons' input samples during the step, and the thermal term's input at the reading."""
    kel = device.kelvin_per_V2
    n = plan.v.size
    P = kel * plan.v**2
    hold = plan.R - plan.T

    amb = None
    if "ambient_drift" in eff:
        form, s = eff["ambient_drift"]
        grid, path = paths.drift_path(form, paths.stream(seed, "ambient_drift"), float(plan.R[-1]) + 60.0)
        amp = s * form["amplitude_K"]
        amb = lambda t: amp * np.interp(t, grid, path)  # noqa: E731

    if "thermal_lag" in eff:
        form, s = eff["thermal_lag"]
        taus, c = paths.lag_spectrum(form)
        r = form["asym_ratio"]
        if form["asymmetry"] == "heating_slower":
            tau_up, tau_dn = taus * np.sqrt(r), taus / np.sqrt(r)
        elif form["asymmetry"] == "cooling_slower":
            tau_up, tau_dn = taus / np.sqrt(r), taus * np.sqrt(r)
        else:
            tau_up = tau_dn = taus
        w = 1.0 - np.exp(-s * form["weight"])
        wb = w * form["beam_share"]
        theta = np.zeros(taus.size)
        frac = np.array([0.0, 0.15, 1.0])
        times = np.empty((n, 3))
        rise_f = np.empty((n, 3))
        rise_b = np.empty(n)
        for k in range(n):
            tau = np.where(P[k] >= theta, tau_up, tau_dn)
            tk = hold[k] * frac
            states = P[k] + (theta - P[k]) * np.exp(-tk[:, None] / tau[None, :])
            slow = states @ c
            rise_f[k] = (1.0 - w) * P[k] + w * slow
            rise_b[k] = (1.0 - wb) * P[k] + wb * slow[-1]
            times[k] = plan.T[k] + tk
            theta = P[k] + (theta - P[k]) * np.exp(-(plan.nxt[k] - plan.T[k]) / tau)
        if amb is not None:
            rise_f = rise_f + amb(times)
        x_samples = device.equivalent_voltage(rise_f)
        v_th = device.equivalent_voltage(rise_b)
        return [list(map(float, row)) for row in x_samples], v_th, rise_b

    if amb is not None:
        times = np.stack([plan.T, plan.R], 1)
        x_samples = device.equivalent_voltage(P[:, None] + amb(times))
        return [list(map(float, row)) for row in x_samples], plan.v.copy(), P

    return [[float(v)] for v in plan.v], plan.v.copy(), P


# ---------------------------------------------------------------------------------------------
# stage 2: film


class _Film:
    def __init__(self, device, info: DeviceInfo, eff: dict):
        self.device, self.info = device, info
        self.h = device.hysteresis()
        self.x = device.v_min_V
        self.p = self.pb = self.h.value()  # effective and base phase parts
        self.inter = None
        if "interaction" in eff:
            form, s = eff["interaction"]
            gmax = 0.6
            g = gmax * (1.0 - np.exp(-s * form["loop_gain"] / gmax))
            c_V = form["sign"] * g / info.slope_max  # V per um of phase deflection
            p0 = -info.phase_swing if form["reference"] == "insulating" else 0.0
            if form["units"] == "temperature":  # a shift of the transition temperature
                c_K = c_V * 2.0 * device.kelvin_per_V2 * info.x_slope
                kel = device.kelvin_per_V2
                self.inter = lambda x, p: float(device.equivalent_voltage(kel * x * x + c_K * (p - p0)))
            else:
                self.inter = lambda x, p: x + c_V * (p - p0)
        self.acc = None
        if "accommodation" in eff:
            self._setup_accommodation(*eff["accommodation"])

    # -- accommodation: the weights change with the number of cycles the film has gone through
    def _setup_accommodation(self, form: dict, s: float) -> None:
        info, dens = self.info, self.device.density_um
        a, b = info.alpha, info.beta
        pat = form["pattern"]
        wsum = max(dens.sum(), 1e-12)
        if pat == "amplitude":
            pattern = np.ones_like(dens)
        elif pat in ("shift", "width"):
            m = 0.5 * (a + b) if pat == "shift" else (a - b)
            mc = float(dens @ m / wsum)
            sd = float(np.sqrt(dens @ (m - mc) ** 2 / wsum)) + 0.05
            pattern = np.tanh((m - mc) / sd)
        else:
            vmax = self.device.v_max_V
            pattern = np.zeros_like(dens)
            for ca, cb, w, amp in form["bumps"]:
                pattern += amp * np.exp(-((a / vmax - ca) ** 2 + (b / vmax - cb) ** 2) / (2 * w * w))
            pattern /= max(np.max(np.abs(pattern)), 1e-12)
        if pat != "amplitude":
            # redistributions change the loop's shape more than its size: weight them up, so that the
            # density-weighted mean |change| matches the amplitude pattern's (the factor capped at 5)
            mean_abs = float(dens @ np.abs(pattern) / wsum)
            target = 1.0 if pat == "patchy" else 2.0
            pattern = pattern * min(target / max(mean_abs, 1e-12), 5.0)
        self.acc = dict(form=form, s=s, pattern=pattern, n=0.0, f_prev=0.0, f_ext=0.0, direction=0)
        self.p = self._acc_phase(np.array(self.h._curve.signed_areas(self.h._grid), float))

    def _acc_law(self, n: float) -> float:
        form = self.acc["form"]
        z = n / form["n0"]
        if form["law"] == "saturating":
            return (1.0 - np.exp(-z)) / (1.0 - np.exp(-3.0))
        if form["law"] == "log":
            return np.log1p(z) / np.log(4.0)
        return (z / 3.0) ** form["q"]

    def _acc_phase(self, areas: np.ndarray) -> float:
        acc, dens = self.acc, self.device.density_um
        f = (float(dens @ areas) + self.info.phase_swing) / (2.0 * self.info.phase_swing)
        df = f - acc["f_prev"]
        if acc["form"]["counter"] == "throughput":
            acc["n"] += 0.5 * abs(df)
        elif df != 0.0:
            d = 1 if df > 0 else -1
            if acc["direction"] != 0 and d != acc["direction"] and abs(acc["f_prev"] - acc["f_ext"]) > 0.02:
                acc["n"] += 0.5
                acc["f_ext"] = acc["f_prev"]
            acc["direction"] = d
        acc["f_prev"] = f
        form = acc["form"]
        factor = np.exp(acc["s"] * form["sign"] * form["epsilon"] * self._acc_law(acc["n"]) * acc["pattern"])
        return float((dens * factor) @ areas)

    # -- moving the film
    def _solve(self, x: float) -> float:
        """The hysterons' input z = G(x, phase(z)), phase from the current memory (loop gain < 1)."""
        G, h = self.inter, self.h
        tol = 1e-10
        z0 = G(x, self.pb)
        phi0 = z0 - G(x, h.peek(z0))
        if abs(phi0) < tol:
            return z0
        lo = hi = None
        if phi0 < 0:
            lo = (z0, phi0)
        else:
            hi = (z0, phi0)
        z1 = z0 - phi0
        zp, phip = z0, phi0
        z = z1
        for _ in range(60):
            phi = z - G(x, h.peek(z))
            if abs(phi) < tol:
                return z
            if phi < 0:
                lo = (z, phi)
            else:
                hi = (z, phi)
            zn = z - phi * (z - zp) / (phi - phip) if phi != phip else z - phi
            if lo is not None and hi is not None:
                a, b = sorted((lo[0], hi[0]))
                if not (a < zn < b):
                    zn = 0.5 * (a + b)
                if b - a < tol:
                    return zn
            zp, phip, z = z, phi, zn
        return z

    def move(self, x: float) -> float:
        z = self._solve(x) if self.inter is not None else x
        p = self.pb = self.h.move(z)
        self.x = x
        if self.acc is not None:
            p = self._acc_phase(np.array(self.h._curve.signed_areas(self.h._grid), float))
        self.p = p
        return p


# ---------------------------------------------------------------------------------------------
# stage 3: deflection terms


def _joule_F(form: dict, r: np.ndarray, device, info: DeviceInfo) -> np.ndarray:
    shape = form["shape"]
    if shape == "pure_power":
        return r
    if shape == "alpha_linear_T":
        k = form["kappa"]
        return (r + k * r * r) / (1.0 + k)
    if shape == "alpha_step":
        k = form["kappa"]
        t_mid = 0.5 * (device.transition_heating_C + device.transition_cooling_C) - device.ambient_C
        rc = (t_mid + form["centre_shift_K"]) / info.r_max
        w = form["width_factor"] * device.transition_width_C / info.r_max
        F = lambda q: q + k * w * (_softplus((q - rc) / w) - _softplus(-rc / w))  # noqa: E731
        return F(r) / F(1.0)
    g = form["gamma"]
    return (1.0 - np.exp(-g * r)) / (1.0 - np.exp(-g))


def _joule_term(form, s, device, info, v_th, rise_b):
    z = np.linspace(0.0, 1.0, 201)
    vmax = device.v_max_V
    res = _affine_residual_peak(z, vmax * _joule_F(form, z * z, device, info) - vmax * z)
    per_unit = abs(device.thermal_um_per_V) * max(res, 1e-6)
    lam = s * form["blend"] * min(0.01 * info.swing / per_unit, 1.0)
    r = np.asarray(rise_b, float) / info.r_max
    return device.thermal_um_per_V * lam * (vmax * _joule_F(form, r, device, info) - v_th)


def _reversible_shape(form: dict, q: np.ndarray, device, info: DeviceInfo) -> np.ndarray:
    z = np.clip(np.asarray(q, float) / device.v_max_V, 0.0, None)
    shape = form["shape"]
    if shape == "sigmoid":
        return _sigmoid((np.asarray(q, float) - info.x_mid - form["centre_shift_V"]) / form["width_V"])
    if shape == "bump":
        return np.exp(-((z - form["centre"]) ** 2) / (2 * form["width"] ** 2))
    if shape == "power":
        return z ** form["p"]
    if shape == "cosines":
        return sum(c * (1.0 - np.cos(np.pi * (m + 1) * z)) for m, c in enumerate(form["coefs"]))
    return form["width"] * _softplus((z - form["knee"]) / form["width"])


def _reversible_term(form, s, device, info, v, x_read):
    qg = np.linspace(0.0, device.v_max_V, 301)
    fg = _reversible_shape(form, qg, device, info) - _reversible_shape(form, np.zeros(1), device, info)[0]
    res = _affine_residual_peak(qg, fg)
    norm = max(res, 0.3 * float(np.max(np.abs(fg))), 1e-12)
    q = v if form["argument"] == "voltage" else x_read
    f0 = _reversible_shape(form, np.zeros(1), device, info)[0]
    return s * form["sign"] * form["amplitude_frac"] * info.swing * (_reversible_shape(form, q, device, info) - f0) / norm


def _creep_term(form, s, plan: Plan, driver: np.ndarray, rest: float, ref: float) -> np.ndarray:
    """Nonlinear hereditary creep (Schapery-like).

    z(t) = sum_k step_k psi(t - T_k) / ref is the part of the driver's changes that the beam has not
    followed yet (the driver minus a kernel-weighted average of its past: bounded by its range).
    Relaxation upwards runs on the kernel, downwards on the kernel stretched by ``tau_ratio_down``;
    the deflection is a nonlinear, direction-dependent function of z."""
    d = np.concatenate([[rest], driver])
    step = np.diff(d)
    tt = plan.R[:, None] - plan.T[None, :]
    mask = np.tril(np.ones((plan.v.size, plan.v.size), bool))
    tt = np.where(mask, tt, 0.0)
    z_up = np.where(mask, paths.relaxation(form, tt, 1.0), 0.0) @ step / ref
    z_dn = np.where(mask, paths.relaxation(form, tt, form["tau_ratio_down"]), 0.0) @ step / ref
    z = np.maximum(z_up, 0.0) + np.minimum(z_dn, 0.0)
    r = form["up_down_ratio"]
    dirw = np.where(z > 0, np.sqrt(r), 1.0 / np.sqrt(r))
    amount = np.sign(z) * 0.5 * (np.abs(z) / 0.5) ** form["exponent"] * dirw
    sense = -1.0 if form["sense"] == "lag" else 1.0
    return sense * s * form["fraction"] * ref * amount


# ---------------------------------------------------------------------------------------------
# stage 4: mechanics


def _play(u: np.ndarray, r_up: float, r_dn: float, start: float) -> np.ndarray:
    out = np.empty_like(u)
    m = start + r_dn  # at rest after a long cool-down the mount sits on the upper side of the play
    for i, ui in enumerate(u):
        m = min(max(m, ui - r_up), ui + r_dn)
        out[i] = m
    return out


def _backlash(form, s, u, rest, info):
    r = s * form["width_frac"] * info.swing
    shape = form["shape"]
    if shape == "asymmetric":
        q = np.sqrt(form["asym_ratio"])
        return _play(u, 2 * r * q / (1 + q), 2 * r / (1 + q), rest)
    if shape == "distributed":
        widths = r * np.exp(form["spread"] * np.linspace(-1.0, 1.0, form["n"]))
        widths *= r / widths.mean()
        return np.mean([_play(u, w, w, rest) for w in widths], 0)
    if shape == "compliant":
        return (1.0 - form["follow"]) * _play(u, r, r, rest) + form["follow"] * u
    return _play(u, r, r, rest)


def _first_point_term(form, s, plan: Plan, info, vmax) -> np.ndarray:
    out = np.zeros(plan.v.size)
    amp0 = s * form["amplitude_frac"] * info.swing
    law = form["size_law"]

    def size(dv):
        z = dv / vmax
        if law == "const":
            return 1.0
        if law == "linear":
            return z
        if law == "sqrt":
            return np.sqrt(z)
        if law == "saturating":
            sc = form["size_scale_V"]
            return (1.0 - np.exp(-dv / sc)) / (1.0 - np.exp(-vmax / sc))
        sc, w = form["size_scale_V"], form["size_width_V"]
        return float(_sigmoid((dv - sc) / w) / _sigmoid((vmax - sc) / w))

    decay = form["decay"]
    if decay == "none":
        weights = np.array([1.0])
    elif decay == "geometric":
        weights = form["ratio"] ** np.arange(8)
    elif decay == "linear":
        weights = 1.0 - np.arange(form["points"]) / form["points"]
    else:
        weights = (1.0 + np.arange(8)) ** (-form["q"])
    for r in np.unique(plan.run[plan.run >= 0]):
        idx = np.nonzero(plan.run == r)[0]
        last_dir, prev_v = 0, 0.0
        for i, k in enumerate(idx):
            dv = plan.v[k] - prev_v
            prev_v = plan.v[k]
            d = 0 if abs(dv) < 1e-12 else (1 if dv > 0 else -1)
            if d == 0:
                continue
            if last_dir != 0 and d != last_dir:
                if form["sense"] == "along":
                    sg = d
                elif form["sense"] == "against":
                    sg = -d
                else:
                    sg = form["fixed_sign"]
                dirf = np.sqrt(form["up_factor"]) if d > 0 else 1.0 / np.sqrt(form["up_factor"])
                a = amp0 * sg * dirf * size(abs(dv))
                seg = idx[i:i + weights.size]
                if form["overlap"] == "replace":  # a new reversal ends the lingering of the earlier ones
                    out[idx[i:]] = 0.0
                out[seg] += a * weights[: seg.size]
            last_dir = d
    return out


# ---------------------------------------------------------------------------------------------
# stage 5: sensor


_ZGRID = np.linspace(-8.0, 8.0, 3201)


def _log_slope(form: dict, zeta: np.ndarray, info: DeviceInfo) -> np.ndarray:
    """h(zeta): the log of the PSD map's slope, before scaling."""
    shape = form["shape"]
    L = 0.5 * info.swing
    c = info.u_lo + form["centre_frac"] * info.swing
    to_zeta = lambda fr: (info.u_lo + np.asarray(fr, float) * info.swing - c) / L  # noqa: E731
    if shape in ("tanh", "sinh"):
        ell = form["scale_factor"]
        h = 2.0 * ell * ell * (np.logaddexp(zeta / ell, -zeta / ell) - np.log(2.0))  # 2 l^2 ln cosh(z / l)
        return -h if shape == "tanh" else h
    if shape == "poly":
        return form["b1"] * zeta + form["b2"] * zeta**2
    if shape == "spline":
        knots, coefs, w = to_zeta(form["knots_frac"]), np.array(form["coefs"]), form["width"]
        return np.exp(-((zeta[:, None] - knots[None, :]) ** 2) / (2 * w * w)) @ coefs
    h = np.zeros_like(zeta)
    for zk, dk, wk in zip(to_zeta(form["kink_frac"]), form["kink_dslope"], form["kink_width"]):
        h += dk * _sigmoid((zeta - zk) / wk)
    return h


def _psd_map(form: dict, amount: float, info: DeviceInfo):
    """The calibrated PSD map y -> S(y) for log-slope amount * h (monotone for any amount)."""
    L = 0.5 * info.swing
    c = info.u_lo + form["centre_frac"] * info.swing
    slope = np.exp(amount * _log_slope(form, _ZGRID, info))
    integ = np.concatenate([[0.0], np.cumsum(0.5 * (slope[1:] + slope[:-1]) * np.diff(_ZGRID))])
    integ -= np.interp(0.0, _ZGRID, integ)

    def G(y):
        return c + L * np.interp((np.asarray(y, float) - c) / L, _ZGRID, integ)

    # the lab calibrates the PSD against CCD images over the working range: gain and offset are right
    yg = np.linspace(info.u_lo, info.u_hi, 301)
    gy = G(yg)
    (a, b), *_ = np.linalg.lstsq(np.vstack([np.ones_like(gy), gy]).T, yg, rcond=None)
    res = float(np.max(np.abs(a + b * gy - yg)))
    return (lambda y: a + b * G(y)), res


def _psd_kappa(form: dict, info: DeviceInfo) -> float:
    """The log-slope scale that gives the form's deviation at strength 1."""
    target = form["deviation_frac"] * info.swing
    L = 0.5 * info.swing
    c = info.u_lo + form["centre_frac"] * info.swing
    h = _log_slope(form, (np.linspace(info.u_lo, info.u_hi, 101) - c) / L, info)
    cap = 0.7 / max(float(np.ptp(h)), 1e-12)  # the slope varies by at most a factor 2 over the range
    kappa = min(0.1, cap)
    for _ in range(4):
        _, res = _psd_map(form, kappa, info)
        kappa = min(kappa * target / max(res, 1e-12), cap)
    return kappa


def _nonlinearity(form, s, y, info):
    S, _ = _psd_map(form, s * _psd_kappa(form, info), info)
    return S(y)


def _thermochromic(form, s, y, p, info):
    f = np.clip((p + info.phase_swing) / (2.0 * info.phase_swing), 0.0, 1.0)
    mix = form["mixing"]
    if mix == "linear":
        rho = f
    elif mix == "power":
        rho = f ** form["gamma"]
    else:
        fc, w = form["f_c"], form["width"]
        rho = (_sigmoid((f - fc) / w) - _sigmoid(-fc / w)) / (_sigmoid((1 - fc) / w) - _sigmoid(-fc / w))
    g = np.exp(s * form["sign"] * form["epsilon"] * rho)
    c = info.u_lo + form["centre_frac"] * info.swing
    return c + (y - c) * g


# ---------------------------------------------------------------------------------------------


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md); returns ``{"t_s", "v_V", "y_um"}`` per run (no ``dwell_s``)."""
    eff: dict[str, tuple[dict, float]] = {}
    for family, form, strength in effects:
        if family not in _KNOWN:
            raise ValueError(f"unknown mechanism {family!r}")
        strength = float(strength)
        if not strength >= 0.0:
            raise ValueError("strength must be >= 0")
        if strength > 0.0:
            eff[family] = (form, strength)
    plan = make_plan(schedules, seed)
    info = device_info(device) if eff else None
    n = plan.v.size

    # 1. temperature
    samples, v_th, rise_b = _temperature(device, plan, eff, seed)
    x_read = np.array([row[-1] for row in samples])

    # 2. film
    if not eff:
        h = device.hysteresis()
        p = np.array([h.move(row[0]) for row in samples])
    else:
        film = _Film(device, info, eff)
        p = np.empty(n)
        for k in range(n):
            for x in _turning_points(film.x, samples[k]):
                film.move(x)
            p[k] = film.p

    # 3. deflection
    u = np.array([device.output(float(pk), float(vk)) for pk, vk in zip(p, v_th)])
    if eff:
        rest = device.output(-info.phase_swing, 0.0)
        if "joule_power" in eff:
            u = u + _joule_term(*eff["joule_power"], device, info, v_th, rise_b)
        if "reversible" in eff:
            u = u + _reversible_term(*eff["reversible"], device, info, plan.v, x_read)
        if "creep" in eff:
            form, s = eff["creep"]
            if form["driver"] == "phase":
                u = u + _creep_term(form, s, plan, p, -info.phase_swing, 2.0 * info.phase_swing)
            else:
                u = u + _creep_term(form, s, plan, u, rest, info.swing)
        # 4. mechanics
        if "backlash" in eff:
            u = _backlash(*eff["backlash"], u, rest, info)
        fp = None
        if "first_point" in eff:
            fp = _first_point_term(*eff["first_point"], plan, info, device.v_max_V)
            if eff["first_point"][0]["stage"] == "mechanics":
                u = u + fp
        # 5. sensor
        if "sensor_nonlinearity" in eff:
            u = _nonlinearity(*eff["sensor_nonlinearity"], u, info)
        if "thermochromic_gain" in eff:
            u = _thermochromic(*eff["thermochromic_gain"], u, p, info)
    y = u

    out = []
    for r in range(len(schedules)):
        idx = np.nonzero(plan.run == r)[0]
        t = plan.R[idx] - plan.run_start[r]
        yr = y[idx].copy()
        span = float(t[-1]) + 60.0 if t.size else 60.0
        if "gain_drift" in eff:
            form, s = eff["gain_drift"]
            grid, path = paths.drift_path(form, paths.stream(seed, "gain_drift", r), span)
            yr = yr * np.exp(s * form["amplitude_rel"] * np.interp(t, grid, path))
        if "first_point" in eff and eff["first_point"][0]["stage"] == "sensor":
            yr = yr + fp[idx]
        if "baseline_drift" in eff:
            form, s = eff["baseline_drift"]
            grid, path = paths.drift_path(form, paths.stream(seed, "baseline_drift", r), span)
            yr = yr + s * form["amplitude_frac"] * info.swing * np.interp(t, grid, path)
        if noise_um is not None and noise_um > 0:
            yr = yr + float(noise_um) * paths.stream(seed, "noise", r).normal(0.0, 1.0, idx.size)
        out.append({"t_s": t, "v_V": plan.v[idx].copy(), "y_um": yr})
    return out
