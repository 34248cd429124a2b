"""One session (identification run + check run) of a VO2 actuator with unmodelled mechanisms.

Physical order of the pipeline at every set-point (see README.md):

    heater power (heater_aging) -> beam / chip / package temperatures (thermal_lag) -> + room (ambient_drift)
    -> film: hysterons (interaction, accommodation) -> phase part
    -> deflection: bias + bimorph term (joule_power) + anhysteretic part (reversible) + creep
    -> lever mount (first_point, backlash)
    -> PSD: response (sensor_nonlinearity) -> gain (gain_drift) -> zero (baseline_drift) -> + noise

The lab's logger: the heater is set at the set-point change, held ``dwell``, then the DAQ takes a burst of
``K`` PSD samples at ``DAQ_SAMPLE_S`` each and averages them; the record's time stamp ``t_s`` is the centre
of the burst (each run from its own start), and the logger writes ``dwell_s`` = time from the set-point
change to that centre (``dwell + K * DAQ_SAMPLE_S / 2``).  The next set-point follows the burst at once.
"""

from __future__ import annotations

import weakref
import zlib

import numpy as np

from . import _noise
from ._film import GAIN_MAX, Film, accommodation_mask
from ._forms import LIBRARY, OUTSIDE
from ._kernels import prony
from ._sensor import response
from ._thermal import ThermalNetwork

TAG = 0x6E5E_2026
DAQ_SAMPLE_S = 0.005          # PSD sampling interval of the burst (200 S/s)
GAP_S = 600.0                 # nominal heater-off pause between the runs
KB_EV = 8.617333262e-5
AGING_REF_DOSE_H = 0.5       # heater aging: the power change 'at 1' is reached after this equivalent dose
ACC_REF_CYCLES = 10.0         # accommodation: the weight change 'at 1' is reached after this many cycles
LAG_SAMPLES = np.array([0.04, 0.12, 0.3, 0.6])   # extra film-temperature samples in a dwell (fractions)


def stream(seed: int, name: str) -> np.random.Generator:
    """The random stream of one part of a realisation: depends on (seed, name) only."""
    return np.random.default_rng(np.random.SeedSequence([TAG, int(seed) % (2**63), zlib.crc32(name.encode())]))


# ------------------------------------------------------------------------------------------- device scale
_SCALE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def device_scale(device) -> dict:
    """Output range of the clean major loop, its middle and half-swing, and the phase slopes."""
    if device in _SCALE:
        return _SCALE[device]
    v = np.linspace(device.v_min_V, device.v_max_V, 241)
    h = device.hysteresis()
    Pu = np.array([h.move(x) for x in v])
    Pd = np.array([h.move(x) for x in v[::-1]])[::-1]
    uu = device.bias_um + device.thermal_um_per_V * v + Pu
    ud = device.bias_um + device.thermal_um_per_V * v + Pd
    lo, hi = float(min(uu.min(), ud.min())), float(max(uu.max(), ud.max()))
    dv = np.diff(v)
    dth = np.diff(device.kelvin_per_V2 * v**2)
    slope_V = max(np.max(np.abs(np.diff(Pu)) / dv), np.max(np.abs(np.diff(Pd)) / dv))
    slope_T = max(np.max(np.abs(np.diff(Pu)) / dth), np.max(np.abs(np.diff(Pd)) / dth))
    info = {"lo": lo, "hi": hi, "mid": 0.5 * (lo + hi), "U": 0.5 * (hi - lo), "swing": hi - lo,
            "slope_V": float(slope_V), "slope_T": float(slope_T),
            "theta_max": float(device.kelvin_per_V2 * device.v_max_V**2),
            "T_mid": 0.5 * (device.transition_heating_C + device.transition_cooling_C)}
    _SCALE[device] = info
    return info


# ------------------------------------------------------------------------------------------- static laws
def joule_map(device, form: dict, sc: dict):
    """``F(theta_b)``: the bimorph's 'equivalent volts' when it follows the temperature rise with alpha(T)."""
    th_max = sc["theta_max"]
    th_c = sc["T_mid"] - device.ambient_C
    beta, step, w = float(form["beta"]), float(form["step"]), max(float(form["step_width_K"]), 1e-6)

    def E(th):
        th = np.asarray(th, float)
        out = th + beta * th * th / (2.0 * th_max)
        if step != 0.0:
            out = out + step * w * (np.logaddexp(0.0, (th - th_c) / w) - np.logaddexp(0.0, -th_c / w))
        return out

    e_max = float(E(th_max))
    return lambda th: device.v_max_V * E(th) / e_max


def reversible_map(device, form: dict, sc: dict):
    """Unit-peak anhysteretic shape, as a function of (film rise theta_f, heater voltage v); zero at rest."""
    kind = form["kind"]
    th_max = sc["theta_max"]
    Tm = sc["T_mid"] + float(form.get("offset_K", 0.0))
    W = float(form.get("width_factor", 1.0)) * device.transition_width_C

    def raw(th, v):
        T = device.ambient_C + th
        if kind == "precursor_sigmoid":
            return np.tanh((T - Tm) / W)
        if kind == "softening_peak":
            q = (T - Tm) / W
            return np.exp(-0.5 * q * q) if form["profile"] == "gaussian" else 1.0 / (1.0 + q * q)
        if kind == "elastic_poly":
            q = th / th_max
            return form["c2"] * q * q + form["c3"] * q**3
        q = (v / device.v_max_V) if form["variable"] == "heater_voltage" else th / th_max
        return -np.expm1(-q / form["scale"])

    vg = np.linspace(device.v_min_V, device.v_max_V, 401)
    tg = device.kelvin_per_V2 * vg**2
    r0 = raw(0.0, 0.0)
    peak = float(np.max(np.abs(raw(tg, vg) - r0)))
    peak = peak if peak > 1e-12 else 1.0
    return lambda th, v: (raw(th, v) - r0) / peak


def size_law(form: dict, swing: float):
    law = form["size_law"]
    if law == "linear":
        g = lambda d: d  # noqa: E731
    elif law == "power":
        p = float(form["size_power"])
        g = lambda d: np.sign(d) * swing * (abs(d) / swing) ** p  # noqa: E731
    else:
        sc = float(form["saturation_frac"]) * swing
        g = lambda d: sc * np.tanh(d / sc)  # noqa: E731
    r = float(form["down_ratio"])
    return lambda d: g(d) * (r if d < 0 else 1.0)


def reversal_size(form: dict, dv: float, v_max: float) -> float:
    law = form["size_law"]
    a = abs(dv)
    if law in ("stick_slip", "saturating"):
        return float(-np.expm1(-a / form["v0_V"]))
    if law == "power":
        return float((a / v_max) ** form["power"])
    return float(1.0 / (1.0 + np.exp(-(a - form["threshold_V"]) / form["threshold_width_V"])))


def aging_kinetics(kind: str, x: float) -> float:
    if kind == "first_order":
        return float(-np.expm1(-x))
    if kind == "parabolic":
        return float(np.sqrt(max(x, 0.0)))
    return float(np.log1p(max(x, 0.0)))


def sensor_c1(form: dict, sc: dict) -> float:
    """Nonlinearity parameter per unit strength: peak deviation over the clean range = peak_frac * swing."""
    z = np.linspace(-1.0 - form["zero_offset"], 1.0 - form["zero_offset"], 401)
    c_small = 1e-4
    dev = np.max(np.abs(response(form["kind"], form["sign"], c_small, z, zcap=3.0) - z)) * sc["U"] / c_small
    return float(form["peak_frac_at_1"]) * sc["swing"] / max(dev, 1e-12)


# ------------------------------------------------------------------------------------------- simulate
def _turning_points(x_prev: float, xs: np.ndarray) -> list[float]:
    seq = [x_prev] + [float(x) for x in xs]
    out = []
    for i in range(1, len(seq) - 1):
        if (seq[i] - seq[i - 1]) * (seq[i + 1] - seq[i]) < 0.0:
            out.append(seq[i])
    out.append(seq[-1])
    return out


def simulate(device, schedules, effects, seed, noise_um):
    eff = {}
    for fam, form, strength in effects:
        if fam not in LIBRARY and fam not in OUTSIDE:
            raise ValueError(f"unknown mechanism {fam!r}")
        if float(strength) < 0:
            raise ValueError("strength must be >= 0")
        if float(strength) > 0:
            if fam in eff:
                raise ValueError(f"mechanism {fam!r} given twice")
            eff[fam] = (dict(form), float(strength))

    sc = device_scale(device) if eff else None
    k = device.kelvin_per_V2
    vmax = device.v_max_V

    # ---------------------------------------------------------------- timing (the logger)
    runs = []
    for sch in schedules:
        v = np.asarray(sch["v_V"], dtype=float)
        dwell = np.asarray(sch["dwell_s"], dtype=float)
        K = int(sch.get("readings", 1))
        burst = K * DAQ_SAMPLE_S
        step = dwell + burst
        t_change = np.concatenate([[0.0], np.cumsum(step)[:-1]])
        runs.append({"v": v, "dwell": dwell, "burst": burst, "t_change": t_change,
                     "t_read": t_change + dwell + burst / 2.0, "end": float(np.sum(step))})
    gap = GAP_S * stream(seed, "session").uniform(0.9, 1.2)
    offsets, t0 = [], 0.0
    for r in runs:
        offsets.append(t0)
        t0 += r["end"] + gap
    t_session_end = offsets[-1] + runs[-1]["end"] if runs else 0.0

    # ---------------------------------------------------------------- realisations (strength-free)
    tg = _noise.grid(t_session_end)
    paths = {}
    for fam, key in (("baseline_drift", "baseline_drift"), ("gain_drift", "gain_drift"), ("ambient_drift", "ambient_drift")):
        if fam in eff:
            form = eff[fam][0]
            x = _noise.composite(stream(seed, key), form["components"], tg, offsets)
            if fam == "ambient_drift":
                x = _noise.lowpass(x, float(form["package_tau_s"]))
            x = x - x[0] if fam == "gain_drift" else x - np.mean(x)
            peak = float(np.max(np.abs(x)))
            paths[fam] = x / peak if peak > 0 else x        # unit peak over the session

    def path_at(fam, t):
        return np.interp(t, tg, paths[fam])

    # ---------------------------------------------------------------- mechanism set-up
    net = None
    if "thermal_lag" in eff:
        form, s = eff["thermal_lag"]
        frac = -np.expm1(-s * float(form["slow_fraction_at_1"]))
        net = ThermalNetwork(k, device.ambient_C, form, frac)
        net.prepare(np.concatenate([r["v"] for r in runs]))

    aging = None
    if "heater_aging" in eff:
        form, s = eff["heater_aging"]
        Ta = device.ambient_C + 273.15
        aging = {"form": form, "s": s, "dose_h": 0.0, "Ta": Ta,
                 "Tref": Ta + form["hotspot_factor"] * k * vmax**2}

    def aging_factor():
        if aging is None:
            return 1.0
        f = aging["form"]
        kin = aging_kinetics(f["kinetics"], aging["dose_h"] / f["dose_scale_h"]) \
            / aging_kinetics(f["kinetics"], AGING_REF_DOSE_H / f["dose_scale_h"])
        e = f["sign"] * aging["s"] * f["power_change_at_1"] * kin
        return float(np.exp(e))

    amb_scale = 0.0
    if "ambient_drift" in eff:
        form, s = eff["ambient_drift"]
        amb_scale = s * float(form["peak_K_at_1"])

    joule = None
    if "joule_power" in eff:
        form, s = eff["joule_power"]
        F = joule_map(device, form, sc)
        vg = np.linspace(device.v_min_V, vmax, 401)
        dev = np.max(np.abs(F(k * vg**2) - vg)) * abs(device.thermal_um_per_V)
        m1 = float(form["peak_frac_at_1"]) * sc["swing"] / max(dev, 1e-12)
        joule = (F, float(-np.expm1(-s * m1)))

    rev = None
    if "reversible" in eff:
        form, s = eff["reversible"]
        rev = (reversible_map(device, form, sc), form["sign"] * s * float(form["peak_frac_at_1"]) * sc["swing"],
               form["variable"])

    inter = None
    if "interaction" in eff:
        form, s = eff["interaction"]
        g = GAIN_MAX * -np.expm1(-s * float(form["gain_at_1"]) / GAIN_MAX)
        q = float(form["quadratic"])
        pr = {"insulating": (0.0, 2.0), "midpoint": (-1.0, 1.0), "metallic": (-2.0, 0.0)}[form["reference"]]
        p_ref = {"insulating": -1.0, "midpoint": 0.0, "metallic": 1.0}[form["reference"]] * device.phase_swing_um
        pg = np.linspace(pr[0], pr[1], 201)
        hprime = float(np.max(np.abs(1.0 + 2.0 * q * pg)))
        hmax = float(np.max(np.abs(pg + q * pg * pg)))
        slope = sc["slope_T"] if form["units"] == "temperature" else sc["slope_V"]
        inter = {"units": form["units"], "kappa": g / (hprime * slope), "sign": int(form["sign"]), "quad": q,
                 "p_ref": p_ref, "swing": device.phase_swing_um, "k": k, "hmax": hmax}

    acc = None
    if "accommodation" in eff:
        form, s = eff["accommodation"]
        mask = accommodation_mask(device, form)
        acc = {"form": form, "s": s, "aux": np.asarray(device.density_um, float) * mask, "N": 0.0}

    def acc_factor():
        f = acc["form"]
        def law(n):
            x = n / f["cycles_scale"]
            if f["kinetics"] == "saturating":
                return -np.expm1(-x)
            if f["kinetics"] == "power":
                return x ** f["power"]
            return np.log1p(x)

        kin = law(acc["N"]) / law(ACC_REF_CYCLES)
        return float(0.9 * np.tanh(acc["s"] * f["amplitude_at_1"] * kin / 0.9))

    creep = None
    if "creep" in eff:
        form, s = eff["creep"]
        w, tau = prony(form)
        creep = {"w": w, "tau": tau, "g": size_law(form, sc["swing"]), "driver": form["driver"],
                 "amp": -form["sign"] * s * float(form["amplitude_at_1"]), "e": np.zeros_like(w), "t_last": 0.0,
                 "D": None}

    fp = None
    if "first_point" in eff:
        form, s = eff["first_point"]
        fp = {"form": form, "up": s * form["amp_up_frac_at_1"] * sc["swing"],
              "down": s * form["amp_down_frac_at_1"] * sc["swing"], "events": [], "last_dir": None}

    bl = None
    if "backlash" in eff:
        form, s = eff["backlash"]
        b = s * float(form["half_play_frac_at_1"]) * sc["swing"] * np.asarray(form["widths_rel"], float)
        asym = float(form["asymmetry"])
        bl = {"b_lo": b * (1.0 + asym), "b_hi": b * (1.0 - asym), "w": np.asarray(form["weights"], float),
              "y": None, "side": int(form["initial_side"])}

    snl = None
    if "sensor_nonlinearity" in eff:
        form, s = eff["sensor_nonlinearity"]
        snl = {"kind": form["kind"], "sign": int(form["sign"]), "c": s * sensor_c1(form, sc),
               "uc": sc["mid"] + float(form["zero_offset"]) * sc["U"], "U": sc["U"]}

    gain = None
    if "gain_drift" in eff:
        form, s = eff["gain_drift"]
        gain = {"scale": s * float(form["peak_rel_at_1"]), "uz": sc["mid"] + float(form["zero_offset"]) * sc["U"]}

    bsl = None
    if "baseline_drift" in eff:
        form, s = eff["baseline_drift"]
        bsl = s * float(form["peak_frac_at_1"]) * sc["swing"]

    thermal_input = net is not None or aging is not None or "ambient_drift" in eff
    thermal_term = net is not None or aging is not None or joule is not None

    def elastic_rest(film_P):
        u = device.output(film_P, 0.0)
        if rev is not None:
            u += rev[1] * float(rev[0](0.0, 0.0))
        return u

    def creep_step(D, t_change):
        """Register the change of the creep driver at ``t_change`` (session time)."""
        if creep["D"] is not None:
            d = D - creep["D"]
            creep["e"] = creep["e"] * np.exp(-(t_change - creep["t_last"]) / creep["tau"])
            if d != 0.0:
                creep["e"] = creep["e"] + creep["w"] * creep["g"](d)
            creep["t_last"] = t_change
        creep["D"] = D

    def creep_value(t):
        return creep["amp"] * float(np.sum(creep["e"] * np.exp(-(t - creep["t_last"]) / creep["tau"])))

    def play(u):
        if bl["y"] is None:
            bl["y"] = u + bl["side"] * 0.5 * (bl["b_hi"] + bl["b_lo"])
        bl["y"] = np.minimum(np.maximum(bl["y"], u - bl["b_lo"]), u + bl["b_hi"])
        return float(bl["w"] @ bl["y"]) / float(bl["w"].sum())

    noise_rng = stream(seed, "noise")
    outputs = []
    film = None
    for ri, run in enumerate(runs):
        off = offsets[ri]
        v_arr, dwell, burst = run["v"], run["dwell"], run["burst"]
        n = v_arr.size
        y = np.empty(n)
        film = Film(device, acc["aux"] if acc is not None else None, inter)
        if acc is not None:
            film.e = acc_factor()
        if creep is not None and creep["D"] is None:
            creep["D"] = film.value() if creep["driver"] == "phase" else elastic_rest(film.value())
        x_prev = device.v_min_V
        v_prev = 0.0
        for i in range(n):
            v = float(v_arr[i])
            tc = off + float(run["t_change"][i])
            tr = off + float(run["t_read"][i])
            # ---------------- temperatures
            if thermal_input or thermal_term:
                pf = aging_factor()
                if net is not None:
                    D = net.drive(v) * pf
                    times = np.concatenate([LAG_SAMPLES * dwell[i], [dwell[i] + burst / 2.0]])
                    th_b = net.trajectory(D, times)
                    net.advance(D, burst / 2.0)
                    t_samples = tc + times
                else:
                    th_b = np.array([k * v * v * pf])
                    t_samples = np.array([tr])
                th_f = th_b + amb_scale * path_at("ambient_drift", t_samples) if amb_scale else th_b
                th_b_read, th_f_read = float(th_b[-1]), float(th_f[-1])
            if thermal_input:
                xs = np.sqrt(np.maximum(th_f, 0.0) / k)
            else:
                xs = np.array([v])
            # ---------------- film
            for x in _turning_points(x_prev, xs):
                film.move(x)
                if acc is not None:
                    acc["N"] += film.dP_base / (4.0 * device.phase_swing_um)
            x_prev = float(xs[-1])
            if acc is not None:
                film.e = acc_factor()             # the weights have changed with the cycles just done
            P = film.value()
            # ---------------- deflection
            if thermal_term:
                v_th = float(np.sqrt(max(th_b_read, 0.0) / k)) if (net is not None or aging is not None) else v
                if joule is not None:
                    v_th = v_th + joule[1] * (float(joule[0](th_b_read if (net is not None or aging is not None) else k * v * v)) - v_th)
            else:
                v_th = v
            u = device.output(P, v_th)
            if rev is not None:
                th_rev = th_f_read if thermal_input else k * v * v
                u += rev[1] * float(rev[0](th_rev, v))
            if creep is not None:
                creep_step(P if creep["driver"] == "phase" else u, tc)
                u += creep_value(tr)
            # ---------------- lever mount
            if fp is not None:
                dv = v - v_prev
                if dv != 0.0:
                    d = 1 if dv > 0 else -1
                    if fp["last_dir"] is not None and d != fp["last_dir"]:
                        a = fp["up"] if d > 0 else fp["down"]
                        fp["events"].append([a * reversal_size(fp["form"], dv, vmax), 0])
                    fp["last_dir"] = d
                off_fp = 0.0
                keep = []
                for ev in fp["events"]:
                    off_fp += ev[0] * fp["form"]["linger_ratio"] ** ev[1]
                    ev[1] += 1
                    if ev[1] <= fp["form"]["linger"]:
                        keep.append(ev)
                fp["events"] = keep
                u += off_fp
            if bl is not None:
                u = play(u)
            # ---------------- PSD
            r = u
            if snl is not None:
                r = snl["uc"] + snl["U"] * float(response(snl["kind"], snl["sign"], snl["c"],
                                                           (r - snl["uc"]) / snl["U"]))
            if gain is not None:
                r = gain["uz"] + float(np.exp(gain["scale"] * path_at("gain_drift", tr))) * (r - gain["uz"])
            if bsl is not None:
                r += bsl * float(path_at("baseline_drift", tr))
            y[i] = r
            # ---------------- heater aging dose during this set-point
            if aging is not None and v > 0.0:
                f = aging["form"]
                Th = aging["Ta"] + f["hotspot_factor"] * k * v * v
                rate = np.exp(-f["activation_eV"] / KB_EV * (1.0 / Th - 1.0 / aging["Tref"]))
                aging["dose_h"] += (dwell[i] + burst) * rate / 3600.0
            v_prev = v
        # ---------------- end of run: heater off for the gap
        t_end = off + run["end"]
        if n and (creep is not None or bl is not None or fp is not None or acc is not None):
            if acc is not None:
                acc["N"] += abs(film.P_base + device.phase_swing_um) / (4.0 * device.phase_swing_um)
            rest = Film(device, acc["aux"] if acc is not None else None, None)
            if acc is not None:
                rest.e = acc_factor()
            P_rest = rest.value()
            u_rest = elastic_rest(P_rest)
            if creep is not None:
                creep_step(P_rest if creep["driver"] == "phase" else u_rest, t_end)
                u_rest += creep_value(t_end + gap)
            if fp is not None and v_prev > 0.0:
                fp["last_dir"] = -1
            if bl is not None:
                play(u_rest)
        if net is not None:
            net.advance(0.0, gap)
        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * noise_rng.standard_normal(n)
        out = {"t_s": run["t_read"].copy(), "v_V": v_arr.copy(), "y_um": y, "dwell_s": dwell + burst / 2.0}
        outputs.append(out)
    return outputs
