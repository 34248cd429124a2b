"""gen_q: unmodelled mechanisms on the VO2 optical-lever rig, seen by an optics engineer.

Physical order of every reading (see README.md):

    heater power -> beam / film temperature (thermal_lag, ambient_drift)
    -> hysterons (interaction, accommodation) -> deflection (joule_power, reversible)
    -> beam mechanics (creep) -> lever mount (backlash) -> spot on the PSD
    (first_point, mode_hop) -> PSD transfer (sensor_nonlinearity) -> gain (gain_drift)
    -> electronic zero (baseline_drift) -> noise.

Only numpy, scipy and ``..base``.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from scipy.signal import lfilter

from ..base import BaseDevice, Hysteresis

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "mode_hop")

_TAG = 0x9E0_51D  # root of every stream of this generator
_NOISE, _TIMING = 1, 2
_DRIFT_DT = 10.0       # s, grid of the drift paths
_HOUR = 3600.0


# ----------------------------------------------------------------------------------------------
# streams
# ----------------------------------------------------------------------------------------------

def _stream(seed: int, run: int, what: int) -> np.random.Generator:
    """A stream of its own for (seed, run, what): runs and mechanisms never share one."""
    return np.random.default_rng(np.random.SeedSequence([_TAG, int(seed) & 0xFFFFFFFF, int(run), int(what)]))


def _family_id(family: str) -> int:
    return 100 + zlib.crc32(family.encode())


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


# ----------------------------------------------------------------------------------------------
# forms
# ----------------------------------------------------------------------------------------------

def _drift_form(rng: np.random.Generator) -> dict:
    """A family of slow random paths (unit rms-ish), the shape only; the path itself comes from the seed."""
    kind = str(rng.choice(["ou", "warmup", "hvac", "brownian", "trend"]))
    form: dict = {"path": kind}
    if kind == "ou":
        form["tau_s"] = _logu(rng, 600.0, 7200.0)
    elif kind == "warmup":
        form["tau_s"] = _logu(rng, 900.0, 5400.0)
        form["wander_tau_s"] = _logu(rng, 600.0, 3600.0)
        form["wander"] = float(rng.uniform(0.15, 0.5))
    elif kind == "hvac":
        n = int(rng.integers(1, 4))
        form["periods_s"] = sorted(_logu(rng, 900.0, 3600.0) for _ in range(n))
        form["slow_tau_s"] = _logu(rng, 1800.0, 7200.0)
        form["slow"] = float(rng.uniform(0.3, 0.8))
    elif kind == "brownian":
        form["smooth_s"] = _logu(rng, 60.0, 600.0)
    else:  # trend
        form["order"] = int(rng.integers(1, 3))
        form["wander_tau_s"] = _logu(rng, 600.0, 3600.0)
        form["wander"] = float(rng.uniform(0.1, 0.4))
    return form


def _g_form(rng: np.random.Generator) -> dict:
    kind = str(rng.choice(["log", "saturating", "power"]))
    form = {"law": kind}
    if kind == "power":
        form["p"] = float(rng.uniform(0.3, 1.0))
    else:
        form["n0"] = _logu(rng, 1.0, 20.0)
    return form


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism (JSON-safe). Does not depend on the strength, nor on other mechanisms."""
    if family == "thermal_lag":
        kind = str(rng.choice(["parallel", "diffusive", "heater_tcr"]))
        if kind == "diffusive":
            lo, hi = _logu(rng, 1.0, 5.0), _logu(rng, 120.0, 900.0)
            taus = list(np.geomspace(lo, hi, 8))
            w = np.power(taus, rng.uniform(-0.5, 0.0))
        else:
            n = int(rng.integers(1, 4))
            taus = sorted(_logu(rng, 2.0, 600.0) for _ in range(n))
            w = rng.dirichlet(np.ones(n))
        w = np.asarray(w, float) / np.sum(w)
        return {"kind": kind, "taus_s": [float(t) for t in taus], "weights": [float(x) for x in w],
                "fraction": float(rng.uniform(0.004, 0.012))}
    if family == "creep":
        kind = str(rng.choice(["single", "discrete", "logspread"]))
        if kind == "single":
            taus, w = [_logu(rng, 5.0, 3 * _HOUR)], np.ones(1)
        elif kind == "discrete":
            n = int(rng.integers(2, 4))
            taus = sorted(_logu(rng, 5.0, 3 * _HOUR) for _ in range(n))
            w = rng.dirichlet(np.ones(n))
        else:
            taus = list(np.geomspace(_logu(rng, 3.0, 60.0), _logu(rng, 1800.0, 3 * _HOUR), 10))
            w = np.power(taus, rng.uniform(-0.5, 0.5))
        w = np.asarray(w, float) / np.sum(w)
        return {"kernel": kind, "taus_s": [float(t) for t in taus], "weights": [float(x) for x in w],
                "fraction": float(rng.uniform(0.008, 0.02)),
                "size_exponent": float(rng.uniform(0.0, 0.5)),
                "asymmetry": float(rng.uniform(-0.5, 0.5)),
                "saturation": float(rng.uniform(0.7, 1.5)),
                "sense": str(rng.choice(["forward", "recovery"])),
                "source": str(rng.choice(["total", "phase"]))}
    if family in ("baseline_drift", "gain_drift", "ambient_drift"):
        form = _drift_form(rng)
        form["amplitude"] = float(rng.uniform(0.7, 1.4))
        if family == "gain_drift":
            form["zero_frac"] = float(rng.uniform(-0.25, 1.25))
        return form
    if family == "joule_power":
        kind = str(rng.choice(["alpha_of_T", "power_law"]))
        form = {"kind": kind, "amplitude": float(rng.uniform(0.7, 1.4))}
        if kind == "alpha_of_T":
            form["gamma"] = float(rng.uniform(-0.4, 0.8))
        else:
            form["exponent"] = float(rng.uniform(1.6, 2.6))
        return form
    if family == "sensor_nonlinearity":
        return {"kind": str(rng.choice(["tanh", "erf", "exp", "pincushion", "barrel"])),
                "centre_offset": float(rng.uniform(-0.8, 0.8)),
                "half_width": float(rng.uniform(0.8, 1.6)),
                "amplitude": float(rng.uniform(0.7, 1.4)),
                "sign": int(rng.choice([-1, 1]))}
    if family == "reversible":
        kind = str(rng.choice(["sigmoid", "power", "bump", "saturating"]))
        form = {"kind": kind, "input": str(rng.choice(["heater", "temperature"])),
                "amplitude": float(rng.uniform(0.7, 1.4)), "sign": int(rng.choice([-1, 1]))}
        if kind in ("sigmoid", "bump"):
            form["centre_K"] = float(rng.uniform(-10.0, 10.0))
            form["width_K"] = float(rng.uniform(3.0, 15.0))
        elif kind == "power":
            form["exponent"] = float(rng.uniform(1.5, 4.0))
        else:
            form["scale"] = float(rng.uniform(0.15, 0.6))
        return form
    if family == "interaction":
        return {"gain": float(rng.uniform(0.03, 0.10)), "sign": int(rng.choice([-1, 1])),
                "reference": str(rng.choice(["centre", "insulating"]))}
    if family == "first_point":
        kind = str(rng.choice(["power", "saturating"]))
        form = {"size_law": kind, "amplitude": float(rng.uniform(0.7, 1.4)),
                "asymmetry": float(rng.uniform(-0.8, 0.8)),
                "sense": str(rng.choice(["overshoot", "lag"]))}
        if kind == "power":
            form["q"] = float(rng.uniform(0.0, 1.0))
        else:
            form["v0_V"] = _logu(rng, 0.1, 2.0)
        linger = str(rng.choice(["none", "geometric", "box"]))
        form["linger"] = linger
        if linger == "geometric":
            form["ratio"] = float(rng.uniform(0.2, 0.6))
        elif linger == "box":
            form["length"] = int(rng.integers(2, 4))
        return form
    if family == "backlash":
        return {"kind": str(rng.choice(["play", "distributed"])),
                "width": float(rng.uniform(0.8, 1.6)),
                "asymmetry": float(rng.uniform(-0.5, 0.5)),
                "init": str(rng.choice(["settled_down", "centred", "settled_up"]))}
    if family == "accommodation":
        return {"scope": str(rng.choice(["per_grain", "global"])),
                "sense": str(rng.choice(["training", "fatigue"])),
                "amplitude": float(rng.uniform(0.6, 1.4)), **_g_form(rng)}
    if family == "mode_hop":
        n = int(rng.integers(1, 4))
        return {"mount_tau_s": _logu(rng, 300.0, 2400.0),
                "mount_K_full": float(rng.uniform(1.5, 4.0)),
                "thresholds": sorted(float(rng.uniform(0.08, 0.6)) for _ in range(n)),
                "hysteresis": float(rng.uniform(0.02, 0.12)),
                "steps": [float(rng.choice([-1, 1]) * rng.uniform(0.6, 1.5)) for _ in range(n)]}
    raise ValueError(f"unknown mechanism {family!r}")


# ----------------------------------------------------------------------------------------------
# drift paths (realisations: from the seed, per run and per mechanism; scaled by the strength later)
# ----------------------------------------------------------------------------------------------

def _ou(e: np.ndarray, tau: float, x0: float) -> np.ndarray:
    a = math.exp(-_DRIFT_DT / tau)
    return lfilter([math.sqrt(1 - a * a)], [1.0, -a], e, zi=[a * x0])[0]


def _drift_path(form: dict, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """Unit-scale slow path at times ``t`` (s from the run's start). Uses the stream in a fixed order."""
    scal = rng.standard_normal(8)
    phases = rng.uniform(0.0, 2 * math.pi, 4)
    n = int(np.ceil(max(float(np.max(t)), 0.0) / _DRIFT_DT)) + 2
    e = rng.standard_normal(n)
    tg = np.arange(n) * _DRIFT_DT
    kind = form["path"]
    if kind == "ou":
        p = _ou(e, form["tau_s"], scal[0])
    elif kind == "warmup":
        p = scal[0] * (1 - np.exp(-tg / form["tau_s"])) * 1.2 + form["wander"] * _ou(e, form["wander_tau_s"], scal[1])
    elif kind == "hvac":
        per = form["periods_s"]
        p = sum(scal[i] * math.sqrt(1.0 / len(per)) * np.sin(2 * math.pi * tg / per[i] + phases[i])
                for i in range(len(per)))
        p = p + form["slow"] * _ou(e, form["slow_tau_s"], scal[4])
    elif kind == "brownian":
        walk = np.cumsum(e) * math.sqrt(_DRIFT_DT / (3 * _HOUR))
        a = math.exp(-_DRIFT_DT / form["smooth_s"])
        p = lfilter([1 - a], [1.0, -a], walk, zi=[a * 0.0])[0] * 1.4
    else:
        s = tg / (3 * _HOUR)
        p = scal[0] * s + (scal[1] * s * s if form["order"] >= 2 else 0.0)
        p = p + form["wander"] * _ou(e, form["wander_tau_s"], scal[2])
    return np.interp(t, tg, p)


# ----------------------------------------------------------------------------------------------
# device scales
# ----------------------------------------------------------------------------------------------

class _Scales:
    """Output range of the clean device (major loop), its steepest phase slope and transition centre."""

    def __init__(self, device: BaseDevice) -> None:
        vs = np.linspace(device.v_min_V, device.v_max_V, 121)
        h = device.hysteresis()
        up = np.array([h.move(v) for v in vs])
        down = np.array([h.move(v) for v in vs[::-1]])
        u = np.concatenate([device.output(up, vs), device.output(down, vs[::-1])])
        self.umin, self.umax = float(np.min(u)), float(np.max(u))
        self.S = max(self.umax - self.umin, 1e-6)
        self.slope = float(np.max(np.abs(np.diff(up) / np.diff(vs))))  # um per V of the phase part
        self.rest = float(device.output(-device.phase_swing_um, 0.0))
        mid_C = 0.5 * (device.transition_heating_C + device.transition_cooling_C)
        self.mid_rise_K = mid_C - device.ambient_C


def _gfun(form: dict, n: np.ndarray | float) -> np.ndarray | float:
    law = form["law"]
    if law == "log":
        return np.log1p(np.asarray(n) / form["n0"]) / math.log1p(10.0 / form["n0"])
    if law == "saturating":
        return -np.expm1(-np.asarray(n) / form["n0"]) / -math.expm1(-10.0 / form["n0"])
    return np.power(np.asarray(n) / 10.0, form["p"])


# ----------------------------------------------------------------------------------------------
# the simulation
# ----------------------------------------------------------------------------------------------

def simulate(device: BaseDevice, schedules, effects, seed: int, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md): one dict per run with t_s, v_V, y_um and dwell_s (logged)."""
    fx: dict[str, tuple[dict, float]] = {}
    for family, form, strength in effects:
        if family not in LIBRARY and family not in OUTSIDE:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if s < 0:
            raise ValueError("strength must be >= 0")
        if s > 0:
            fx[family] = (form, s)
    on = fx.__contains__
    sc = _Scales(device) if fx else None
    k2 = device.kelvin_per_V2
    vmax = device.v_max_V
    one = 0.01 * sc.S if sc else 0.0  # um: "1 % of the swing"

    # --- mechanism constants (depend on form, strength, device) ---
    if on("thermal_lag"):
        f_tl, s_tl = fx["thermal_lag"]
        lag_taus = np.asarray(f_tl["taus_s"], float)
        lag_w = np.asarray(f_tl["weights"], float)
        frac = 0.5 * -math.expm1(-s_tl * f_tl["fraction"] / 0.5)  # continuous, monotone, < 0.5
        lag_tcr = f_tl["kind"] == "heater_tcr"
    if on("interaction"):
        f_in, s_in = fx["interaction"]
        gain = 0.4 * math.tanh(s_in * f_in["gain"] / 0.4)  # loop gain well below one
        lam = f_in["sign"] * gain / max(sc.slope, 1e-9)  # V per um
        p_ref = 0.0 if f_in["reference"] == "centre" else -device.phase_swing_um
    if on("accommodation"):
        f_ac, s_ac = fx["accommodation"]
        c_ac = s_ac * 0.02 * f_ac["amplitude"]
    if on("joule_power"):
        f_jp, s_jp = fx["joule_power"]
        vv = np.linspace(0.0, vmax, 241)

        def _jshape(v):
            w = (np.asarray(v) / vmax) ** 2
            if f_jp["kind"] == "alpha_of_T":
                g = (w + f_jp["gamma"] * w * w) / (1 + f_jp["gamma"])
            else:
                g = np.power(np.asarray(v) / vmax, f_jp["exponent"])
            return vmax * g - np.asarray(v)

        jp_scale = np.sign(device.thermal_um_per_V) * s_jp * one * f_jp["amplitude"] / max(np.max(np.abs(_jshape(vv))), 1e-12)
    if on("reversible"):
        f_rv, s_rv = fx["reversible"]
        vv = np.linspace(0.0, vmax, 241)

        def _rshape_raw(v):
            rise = k2 * np.square(v)
            kind = f_rv["kind"]
            if kind == "sigmoid":
                return np.tanh((rise - sc.mid_rise_K - f_rv["centre_K"]) / f_rv["width_K"])
            if kind == "bump":
                return np.exp(-np.square((rise - sc.mid_rise_K - f_rv["centre_K"]) / f_rv["width_K"]))
            if kind == "power":
                return np.power(np.clip(np.asarray(v) / vmax, 0, None), f_rv["exponent"])
            return -np.expm1(-np.clip(np.asarray(v) / vmax, 0, None) / f_rv["scale"])

        r_base = float(_rshape_raw(0.0))
        rv_scale = f_rv["sign"] * s_rv * one * f_rv["amplitude"] / max(np.ptp(_rshape_raw(vv)), 1e-12)
    if on("creep"):
        f_cr, s_cr = fx["creep"]
        cr_taus = np.asarray(f_cr["taus_s"], float)
        cr_w = np.asarray(f_cr["weights"], float)
        cr_c = s_cr * f_cr["fraction"]
        cr_sign = -1.0 if f_cr["sense"] == "forward" else 1.0
        cr_z = np.zeros_like(cr_taus)
    if on("backlash"):
        f_bl, s_bl = fx["backlash"]
        b = s_bl * 2.0 * one * f_bl["width"]
        b_lo, b_hi = 0.5 * b * (1 + f_bl["asymmetry"]), 0.5 * b * (1 - f_bl["asymmetry"])
        if f_bl["kind"] == "play":
            bl_fr = np.array([1.0])
            bl_w = np.array([1.0])
        else:  # distributed play (Prandtl-Ishlinskii): the mount's flexure takes up the play gradually
            bl_fr = (np.arange(8) + 0.5) / 8
            bl_w = np.full(8, 1 / 8)
        init = {"settled_down": 1.0, "centred": 0.0, "settled_up": -1.0}[f_bl["init"]]
        bl_L, bl_H = bl_fr * b_lo, bl_fr * b_hi  # the band of each play element: m in [u - L, u + H]
        bl_centre = float(bl_w @ (0.5 * (bl_H - bl_L)))
        bl_m = None
    if on("first_point"):
        f_fp, s_fp = fx["first_point"]
        fp_a = s_fp * one * f_fp["amplitude"]
        if f_fp["linger"] == "geometric":
            fp_kernel = f_fp["ratio"] ** np.arange(8)
        elif f_fp["linger"] == "box":
            L = f_fp["length"]
            fp_kernel = 1.0 - np.arange(L) / L
        else:
            fp_kernel = np.array([1.0])
        fp_sense = 1.0 if f_fp["sense"] == "overshoot" else -1.0
    if on("mode_hop"):
        f_mh, s_mh = fx["mode_hop"]
        mh_th = np.asarray(f_mh["thresholds"]) * f_mh["mount_K_full"]
        mh_hy = f_mh["hysteresis"] * f_mh["mount_K_full"]
        mh_steps = np.concatenate([[0.0], np.cumsum(f_mh["steps"])])
        mh_steps = mh_steps / max(1.0, float(np.max(np.abs(mh_steps))) / 1.5) * s_mh * one
        mh_T, mh_mode = 0.0, 0
    if on("sensor_nonlinearity"):
        f_sn, s_sn = fx["sensor_nonlinearity"]
        sn_c = 0.5 * (sc.umin + sc.umax) + f_sn["centre_offset"] * 0.5 * sc.S
        sn_W = 0.5 * sc.S * f_sn["half_width"]
        zmax = max(abs(sc.umin - sn_c), abs(sc.umax - sn_c)) / sn_W
        target = s_sn * one * f_sn["amplitude"] / sn_W  # deviation in units of W at zmax (leading order)
        kind = f_sn["kind"]
        if kind in ("tanh", "erf"):
            sn_k = math.sqrt(3 * target / zmax ** 3)
        elif kind == "exp":
            sn_k = f_sn["sign"] * 2 * target / zmax ** 2
        elif kind == "pincushion":
            sn_k = target / zmax ** 3
        else:
            sn_k = 2 * target / zmax ** 3

        def _psd(u):
            z = (u - sn_c) / sn_W
            if kind == "tanh":
                f = math.tanh(sn_k * z) / sn_k
            elif kind == "erf":
                f = math.erf(sn_k * z) * math.sqrt(math.pi) / (2 * sn_k)
            elif kind == "exp":
                f = math.expm1(sn_k * z) / sn_k
            elif kind == "pincushion":
                f = z + sn_k * z ** 3
            else:
                f = z / math.sqrt(1 + sn_k * z * z)
            return sn_c + sn_W * f
    if on("gain_drift"):
        f_gd, s_gd = fx["gain_drift"]
        gd_z0 = sc.umin + f_gd["zero_frac"] * sc.S
        gd_rel = s_gd * f_gd["amplitude"] * one / max(abs(sc.umin - gd_z0), abs(sc.umax - gd_z0))
    if on("baseline_drift"):
        f_bd, s_bd = fx["baseline_drift"]
        bd_a = s_bd * one * f_bd["amplitude"]
    if on("ambient_drift"):
        f_ad, s_ad = fx["ambient_drift"]
        ad_a = s_ad * 0.3 * f_ad["amplitude"]  # K

    temp_dynamic = on("thermal_lag") or on("ambient_drift")
    h = device.hysteresis()
    h_acc_n = np.zeros_like(device.density_um)  # per-grain cycle counts
    areas_prev = None
    if on("accommodation"):
        areas_prev = h._curve.signed_areas(h._grid)
    lag_z = np.zeros(len(lag_taus)) if on("thermal_lag") else None
    session_end = 0.0  # session time of the end of the previous run
    last_source = 0.0
    if on("creep"):
        last_source = sc.rest if f_cr["source"] == "total" else -device.phase_swing_um
    out = []

    def _feel(x):
        """Move the hysterons to what they feel at film input x (self-consistent with the mean field)."""
        if not on("interaction"):
            return h.move(x)
        xe = x + lam * (h.value() - p_ref)
        for _ in range(80):
            nxt = x + lam * (h.peek(xe) - p_ref)
            if abs(nxt - xe) < 1e-10:
                xe = nxt
                break
            xe = nxt
        return h.move(xe)

    def _move(x):
        nonlocal areas_prev
        p = _feel(x)
        if on("accommodation"):
            a = h._curve.signed_areas(h._grid)
            h_acc_n[:] += np.abs(a - areas_prev) / 4.0
            areas_prev = a
        return p

    for run, sch in enumerate(schedules):
        v_arr = np.asarray(sch["v_V"], float)
        dw_arr = np.asarray(sch["dwell_s"], float)
        K = int(sch.get("readings", 1))
        n = len(v_arr)
        # timing of this run (its own stream): controller latency and the burst
        trng = _stream(seed, run, _TIMING)
        gap = float(trng.uniform(540.0, 660.0)) if run > 0 else 0.0
        latency = trng.uniform(0.005, 0.05, n)
        burst = min(0.02 * K, 0.5)
        t_change = np.concatenate([[0.0], np.cumsum(dw_arr + latency + burst)[:-1]])
        t_read = t_change + dw_arr + latency + 0.5 * burst
        t0 = session_end + gap  # session time of this run's start
        # drift realisations of this run (each mechanism its own stream)
        span = np.concatenate([t_change, t_read])
        if on("ambient_drift"):
            ad_grid_t = np.arange(int(np.ceil(span.max() / _DRIFT_DT)) + 2) * _DRIFT_DT
            ad_vals = ad_a * _drift_path(f_ad, _stream(seed, run, _family_id("ambient_drift")), ad_grid_t)
        if on("baseline_drift"):
            bd_vals = bd_a * _drift_path(f_bd, _stream(seed, run, _family_id("baseline_drift")), t_read)
        if on("gain_drift"):
            gd_vals = gd_rel * _drift_path(f_gd, _stream(seed, run, _family_id("gain_drift")), t_read)

        # --- the gap before the run: heater at 0 V (states relax) ---
        if run > 0:
            if on("thermal_lag"):
                lag_z *= np.exp(-gap / lag_taus)
            if on("mode_hop"):
                mh_T *= math.exp(-gap / f_mh["mount_tau_s"])
        if temp_dynamic:
            if on("thermal_lag"):  # the film's rise (V^2) at 0 V heater with the slow paths' residual heat
                r0 = frac * float(lag_w @ (-lag_z if lag_tcr else lag_z))
            else:
                r0 = 0.0
            dT0 = float(np.interp(0.0, ad_grid_t, ad_vals)) if on("ambient_drift") else 0.0
            x0 = float(device.equivalent_voltage(k2 * r0 + dT0))
            _move(x0)
        elif run > 0:
            _move(device.v_min_V)
        if sc is not None:
            rest_u = device.output(h.value(), 0.0)
        if on("creep") and run > 0:
            # the heater went to 0 V at the end of the previous run: one more change, then the gap
            src_rest = rest_u if f_cr["source"] == "total" else h.value()  # noqa: F821
            d = src_rest - last_source
            cr_z = cr_z + _creep_kick(d, cr_c, cr_w, sc.S, f_cr)
            cr_z = cr_z * np.exp(-gap / cr_taus)
            last_source = src_rest
        if on("backlash"):
            if bl_m is None:
                bl_m = rest_u + 0.5 * (bl_H - bl_L) + init * 0.5 * (bl_H + bl_L)
            bl_m = np.clip(bl_m, rest_u - bl_L, rest_u + bl_H)
        fp_dir = -1  # the heater came down to 0 V before the run
        fp_events: list[tuple[int, float]] = []
        prev_v = 0.0
        prev_change = 0.0

        y = np.empty(n)
        for i in range(n):
            v = float(v_arr[i])
            p_now = v * v
            dwell = float(t_read[i] - t_change[i])
            # ---------------- temperature -> film ----------------
            if temp_dynamic:
                if on("thermal_lag"):
                    # lag_z already at t_change[i] (advanced below), sample the dwell
                    fr = np.array([0.0, 0.03, 0.1, 0.25, 0.5, 0.75, 1.0])
                    ts = fr * dwell
                    decay = np.exp(-ts[:, None] / lag_taus[None, :])
                    zs = p_now + (lag_z[None, :] - p_now) * decay
                    if lag_tcr:
                        rs = p_now + frac * ((p_now - zs) @ lag_w)
                    else:
                        rs = (1 - frac) * p_now + frac * (zs @ lag_w)
                else:
                    ts = np.array([0.0, dwell])
                    rs = np.full(2, p_now)
                if on("ambient_drift"):
                    dTs = np.interp(t_change[i] + ts, ad_grid_t, ad_vals)
                else:
                    dTs = 0.0
                xs = device.equivalent_voltage(k2 * rs + dTs)
                # turning points only (rate-independent memory)
                pts: list[float] = []
                last = h.position
                for xv in xs:
                    xv = float(xv)
                    if not pts:
                        pts.append(xv)
                    else:
                        d_old = pts[-1] - (pts[-2] if len(pts) > 1 else last)
                        if (xv - pts[-1]) * d_old >= 0:
                            pts[-1] = xv
                        else:
                            pts.append(xv)
                for xv in pts:
                    P = _move(xv)
                r_read = float(rs[-1])
                x_film = float(xs[-1])
                v_th = math.sqrt(max(r_read, 0.0))
            else:
                P = _move(v)
                v_th = v
                x_film = v
            # ---------------- film -> deflection ----------------
            if on("accommodation"):
                areas = areas_prev
                if f_ac["scope"] == "per_grain":
                    nn = h_acc_n
                else:
                    nn = np.full_like(h_acc_n, float(device.density_um @ h_acc_n) / max(device.phase_swing_um, 1e-12))
                g = _gfun(f_ac, nn)
                fac = 1 + c_ac * g if f_ac["sense"] == "training" else np.exp(-c_ac * g)
                P_eff = float((device.density_um * fac) @ areas)
            else:
                P_eff = P
            u = device.output(P_eff, v_th)
            if on("joule_power"):
                u += jp_scale * float(_jshape(v_th))
            if on("reversible"):
                vin = v_th if f_rv["input"] == "heater" else x_film
                u += rv_scale * (float(_rshape_raw(vin)) - r_base)
            # ---------------- beam mechanics ----------------
            if on("creep"):
                dtc = float(t_change[i] - prev_change) if i > 0 else 0.0
                cr_z = cr_z * np.exp(-dtc / cr_taus)
                src = u if f_cr["source"] == "total" else P_eff
                cr_z = cr_z + _creep_kick(src - last_source, cr_c, cr_w, sc.S, f_cr)
                last_source = src
                # the relaxable (anelastic) strain is bounded: asymmetric kicks cannot ratchet without limit
                cr_sat = f_cr["saturation"] * cr_c * sc.S
                u += cr_sign * cr_sat * math.tanh(float(np.sum(cr_z * np.exp(-dwell / cr_taus))) / cr_sat)
            # ---------------- lever mount ----------------
            if on("backlash"):
                bl_m = np.clip(bl_m, u - bl_L, u + bl_H)
                u = float(bl_w @ bl_m) - bl_centre
            spot = u
            # ---------------- spot on the PSD ----------------
            if on("first_point"):
                dv = v - prev_v
                if dv != 0.0:
                    d = 1 if dv > 0 else -1
                    if d != fp_dir:
                        mag = abs(dv) / vmax
                        size = mag ** f_fp["q"] if f_fp["size_law"] == "power" else (
                            -math.expm1(-abs(dv) / f_fp["v0_V"]) / -math.expm1(-vmax / f_fp["v0_V"]))
                        amp = fp_a * (1 + d * f_fp["asymmetry"]) * size * fp_sense * d
                        fp_events.append((i, amp))
                    fp_dir = d
                off = 0.0
                for (j, amp) in fp_events[-len(fp_kernel):]:
                    if i - j < len(fp_kernel):
                        off += amp * fp_kernel[i - j]
                spot += off
            if on("mode_hop"):
                tau_m = f_mh["mount_tau_s"]
                T_eq = f_mh["mount_K_full"] * p_now / (vmax * vmax)
                if i > 0:
                    mh_T = T_eq_prev + (mh_T - T_eq_prev) * math.exp(-(t_change[i] - prev_change) / tau_m)
                T_read = T_eq + (mh_T - T_eq) * math.exp(-dwell / tau_m)
                while mh_mode < len(mh_th) and T_read > mh_th[mh_mode] + 0.5 * mh_hy:
                    mh_mode += 1
                while mh_mode > 0 and T_read < mh_th[mh_mode - 1] - 0.5 * mh_hy:
                    mh_mode -= 1
                T_eq_prev = T_eq
                spot += mh_steps[mh_mode]
            # ---------------- PSD ----------------
            reading = _psd(spot) if on("sensor_nonlinearity") else spot
            if on("gain_drift"):
                reading = gd_z0 + (1 + float(gd_vals[i])) * (reading - gd_z0)
            if on("baseline_drift"):
                reading += float(bd_vals[i])
            y[i] = reading
            # advance the slow thermal states to the next change
            if on("thermal_lag"):
                nxt = float(t_change[i + 1] - t_change[i]) if i + 1 < n else dwell + 0.5 * burst
                lag_z = p_now + (lag_z - p_now) * np.exp(-nxt / lag_taus)
            prev_v = v
            prev_change = float(t_change[i])
        run_len = float(t_read[-1] + 0.5 * burst) if n else 0.0
        # mode-hop mount and creep: carry to the end of the run
        if on("mode_hop") and n:
            mh_T = T_eq_prev + (mh_T - T_eq_prev) * math.exp(-(run_len - prev_change) / f_mh["mount_tau_s"])
        if on("creep") and n:
            cr_z = cr_z * np.exp(-(run_len - prev_change) / cr_taus)
        session_end = t0 + run_len
        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * _stream(seed, run, _NOISE).standard_normal(n)
        out.append({"t_s": t_read.copy(), "v_V": v_arr.copy(), "y_um": y,
                    "dwell_s": (t_read - t_change).copy()})
    return out


def _creep_kick(d: float, c: float, w: np.ndarray, S: float, form: dict) -> np.ndarray:
    """The relaxation a change ``d`` (um) of the source starts, spread over the kernel's times."""
    if d == 0.0:
        return np.zeros_like(w)
    size = abs(d) * (abs(d) / S) ** form["size_exponent"]
    direction = 1.0 if d > 0 else -1.0
    return c * (1 + direction * form["asymmetry"]) * direction * size * w
