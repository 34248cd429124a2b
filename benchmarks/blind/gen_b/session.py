"""Generator B's session simulator: the base device plus unmodelled mechanisms, composed in physical order.

temperature (heater power -> thermal network, ambient, heater aging)
  -> film (hysterons, with the stress mean field) and anhysteretic parts
  -> deflection (creep, first-point settling, mount backlash)
  -> sensor (PSD geometry, gain, zero) -> logger (noise, time stamps, dwell).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from ..base import BaseDevice
from .forms import LIBRARY, OUTSIDE
from .physics import CreepUnits, ThermalLag, drift_path, sensor_residual, stream

_KB_EV = 8.617333262e-5
#: Fractions of the dwell at which the film temperature is followed (the hysterons see its extrema).
_DWELL_FRACTIONS = np.array([0.0, 0.005, 0.015, 0.04, 0.08, 0.15, 0.25, 0.4, 0.6, 0.8])
#: The logger's burst: one reading every 2 ms, averaged; the time stamp is the middle of the burst.
_READ_PERIOD_S = 0.002
_TEMPERATURE_FAMILIES = ("thermal_lag", "ambient_drift", "heater_aging", "interaction")


# ----------------------------------------------------------------------------- device profile

class _Profile:
    """What a generator needs to know about the device: output range, cell positions, loop slope."""

    def __init__(self, device: BaseDevice) -> None:
        self.device = device
        L, lo, hi = device.levels, device.v_min_V, device.v_max_V
        self.walls = lo + (hi - lo) * np.arange(L + 1) / L
        h = device.hysteresis()
        up = [device.output(h.move(x), x) for x in self.walls]
        down = [device.output(h.move(x), x) for x in self.walls[::-1]]
        u = np.array(up + down)
        self.u_lo, self.u_hi = float(u.min()), float(u.max())
        self.swing_um = self.u_hi - self.u_lo
        self.half_um = device.phase_swing_um
        self._slope = None
        self._cells = None

    def max_dp_dtheta(self) -> float:
        """Largest slope of the normalised phase ``P / half`` against the film temperature (1/K)."""
        if self._slope is None:
            d = self.device
            x = np.linspace(d.v_min_V, d.v_max_V, 4 * d.levels + 1)
            h = d.hysteresis()
            pu = np.array([h.move(v) for v in x])
            pd = np.array([h.move(v) for v in x[::-1]])[::-1]
            xm = 0.5 * (x[1:] + x[:-1])
            dth = np.maximum(2.0 * d.kelvin_per_V2 * xm * np.diff(x), 1e-12)
            s = max(np.max(np.diff(pu) / dth), np.max(np.diff(pd) / dth)) / max(self.half_um, 1e-12)
            self._slope = float(max(s, 1e-6))
        return self._slope

    def cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres (V) of every cell's switching-up and switching-down thresholds, probed on the walls."""
        if self._cells is None:
            d = self.device
            n = len(d.density_um)
            step = self.walls[1] - self.walls[0]
            alpha = np.full(n, np.nan)
            beta = np.full(n, np.nan)
            neg = d.hysteresis()
            for a, w in enumerate(self.walls[1:], start=1):
                h = neg.copy()
                h.move(w)
                sa = h._curve.signed_areas(h._grid)
                new = (sa > 0) & np.isnan(alpha)
                alpha[new] = w - 0.5 * step
            pos = d.hysteresis()
            pos.move(d.v_max_V)
            for w in self.walls[-2::-1]:
                h = pos.copy()
                h.move(w)
                sa = h._curve.signed_areas(h._grid)
                new = (sa < 0) & np.isnan(beta)
                beta[new] = w + 0.5 * step
            alpha = np.where(np.isnan(alpha), self.walls[-1] - 0.5 * step, alpha)
            beta = np.where(np.isnan(beta), self.walls[0] + 0.5 * step, beta)
            self._cells = (alpha, beta)
        return self._cells


# ----------------------------------------------------------------------------- helpers

def _timing(schedule: dict, rng: np.random.Generator) -> dict:
    v = np.asarray(schedule["v_V"], dtype=float)
    dwell = np.asarray(schedule["dwell_s"], dtype=float)
    K = int(schedule.get("readings", 1))
    n = len(v)
    if n == 0:
        e = np.zeros(0)
        return {"v": v, "dwell": dwell, "t_cmd": e, "t_read": e, "t_next": e, "t_end": 0.0, "K": K}
    burst = K * _READ_PERIOD_S
    overhead = rng.uniform(0.010, 0.030, n)      # DAQ write / software loop between burst and next command
    step = dwell + burst + overhead
    t_cmd = np.concatenate([[0.0], np.cumsum(step)[:-1]])
    t_read = t_cmd + dwell + 0.5 * burst
    return {"v": v, "dwell": dwell, "t_cmd": t_cmd, "t_read": t_read,
            "t_next": t_cmd + step, "t_end": float(t_cmd[-1] + step[-1]), "K": K}


def _turning_points(x0: float, xs: np.ndarray) -> list[float]:
    out = [x0]
    for x in xs:
        x = float(x)
        if x == out[-1]:
            continue
        if len(out) >= 2 and (x - out[-1]) * (out[-1] - out[-2]) > 0:
            out[-1] = x
        else:
            out.append(x)
    return out[1:] if len(out) > 1 else [x0]


def _accommodation_law(form: dict, n_cycles: float) -> float:
    n0, ref = form["n0_cycles"], 20.0
    if form["law"] == "exp":
        return -math.expm1(-n_cycles / n0) / -math.expm1(-ref / n0)
    if form["law"] == "log":
        return math.log1p(n_cycles / n0) / math.log1p(ref / n0)
    return (n_cycles / ref) ** form["power"]


def _aging_law(form: dict, dose_s: float) -> float:
    d0, ref = form["d0_s"], 3600.0
    law = form["law"]
    if law == "saturating":
        return -math.expm1(-dose_s / d0) / -math.expm1(-ref / d0)
    if law == "parabolic":
        return math.sqrt(dose_s / ref)
    if law == "log":
        return math.log1p(dose_s / d0) / math.log1p(ref / d0)
    return dose_s / ref


# ----------------------------------------------------------------------------- the session

class _Session:
    def __init__(self, device: BaseDevice, active: dict, seed: int) -> None:
        self.d = device
        self.a = active
        self.seed = int(seed)
        self.prof = _Profile(device) if active else None
        self.temp = any(f in active for f in _TEMPERATURE_FAMILIES)
        self.h = device.hysteresis()
        self.P = self.h.value()
        self.x_in = self.h.position        # the input the film last felt, before the mean field
        # thermal network
        self.lag = None
        if "thermal_lag" in active:
            form, s = active["thermal_lag"]
            share = 0.8 * math.tanh(s * form["share_at_1"] / 0.8)
            w = share * np.asarray(form["mode_weight"], float)
            self.lag = ThermalLag(np.asarray(form["mode_tau_s"], float), w, form["tcr_feedback_per_K"])
        # stress mean field
        if "interaction" in active:
            form, s = active["interaction"]
            gain_per_K = (1.0 + 2.0 * abs(form["quadratic"])) * self.prof.max_dp_dtheta()
            cap = form["max_loop_gain"] / gain_per_K
            self.beta_K = form["sign"] * cap * math.tanh(s * form["shift_K_at_1"] / cap)
        # training / fatigue of the weights
        self.h2 = None
        self.cycles = 0.0
        if "accommodation" in active:
            form, _ = active["accommodation"]
            pat = form["pattern"]
            if pat not in ("fatigue", "training_gain"):
                alpha, beta = self.prof.cells()
                rho = np.maximum(device.density_um, 0.0)
                wsum = max(float(rho.sum()), 1e-300)
                if pat in ("shift_up", "shift_down"):
                    c = 0.5 * (alpha + beta)
                else:
                    c = alpha - beta
                mean = float(rho @ c) / wsum
                sd = math.sqrt(max(float(rho @ (c - mean) ** 2) / wsum, 1e-12))
                pattern = (c - mean) / sd
                if pat in ("shift_down", "narrowing"):
                    pattern = -pattern
                self.h2 = replace(device, density_um=device.density_um * pattern).hysteresis()
        self.P2 = self.h2.value() if self.h2 is not None else 0.0
        self.dose = 0.0

    # -- temperature ------------------------------------------------------------------------------
    def _aging_factor(self) -> float:
        if "heater_aging" not in self.a:
            return 1.0
        form, s = self.a["heater_aging"]
        return 1.0 + form["sign"] * s * form["change_at_1"] * _aging_law(form, self.dose)

    def _dose_rate(self, v: float) -> float:
        form, _ = self.a["heater_aging"]
        d = self.d
        t_ref = 273.15 + d.ambient_C + float(d.rise_K(0.8 * d.v_max_V))
        t = 273.15 + d.ambient_C + float(d.rise_K(v))
        return math.exp(-form["ea_eV"] / _KB_EV * (1.0 / t - 1.0 / t_ref))

    # -- film -------------------------------------------------------------------------------------
    def _delta_T(self, P: float) -> float:
        form, _ = self.a["interaction"]
        p = P / self.d.phase_swing_um
        p0, q = form["stress_free_p"], form["quadratic"]
        return self.beta_K * ((p - p0) + q * (p * p - p0 * p0))

    def _move_to_theta(self, theta_in: float) -> None:
        """Move the film to the film-temperature rise ``theta_in`` (K), with the mean field if present."""
        eq = self.d.equivalent_voltage
        self.x_in = float(eq(theta_in))
        if "interaction" not in self.a:
            self._move(float(eq(theta_in)))
            return
        h = self.h

        def G(z: float) -> float:
            return float(eq(theta_in + self._delta_T(h.peek(z))))

        z0 = float(eq(theta_in + self._delta_T(self.P)))
        z1 = G(z0)
        f0 = z0 - z1
        if abs(f0) > 1e-11:
            ok = False
            za, fa = z0, f0
            zb = z1
            for _ in range(12):
                fb = zb - G(zb)
                if abs(fb) < 1e-11:
                    ok = True
                    break
                if fb == fa:
                    break
                zc = zb - fb * (zb - za) / (fb - fa)
                za, fa, zb = zb, fb, zc
            if ok:
                z1 = zb
            else:
                ends = [self._delta_T(-self.d.phase_swing_um), self._delta_T(self.d.phase_swing_um)]
                lo = float(eq(theta_in + min(ends))) - 1e-9
                hi = float(eq(theta_in + max(ends))) + 1e-9
                z1 = brentq(lambda z: z - G(z), lo, hi, xtol=1e-12)
        self._move(z1)

    def _move(self, x: float) -> None:
        P = self.h.move(x)
        if "accommodation" in self.a:
            self.cycles += abs(P - self.P) / (4.0 * self.d.phase_swing_um)
            if self.h2 is not None:
                self.P2 = self.h2.move(x)
        self.P = P

    def _phase_out(self) -> float:
        if "accommodation" not in self.a:
            return self.P
        form, s = self.a["accommodation"]
        delta = s * form["change_at_1"] * _accommodation_law(form, self.cycles)
        if form["pattern"] == "fatigue":
            return self.P * (1.0 - delta)
        if form["pattern"] == "training_gain":
            return self.P * (1.0 + delta)
        return self.P + delta * self.P2

    # -- one run ----------------------------------------------------------------------------------
    def run_film(self, tm: dict, amb: tuple | None) -> dict:
        """Simulate the film through one run; returns per-reading phase, v_thermal, film temperature."""
        d = self.d
        v_arr = tm["v"]
        n = len(v_arr)
        P_out = np.empty(n)
        v_th = np.empty(n)
        theta_rd = np.empty(n)

        def ambient(t):
            return np.interp(t, amb[0], amb[1]) if amb is not None else 0.0

        for i in range(n):
            v = float(v_arr[i])
            if not self.temp:
                self._move(v)
                P_out[i] = self._phase_out()
                v_th[i] = v
                theta_rd[i] = float(d.rise_K(v))
                continue
            tc, tr, tn = tm["t_cmd"][i], tm["t_read"][i], tm["t_next"][i]
            if "heater_aging" in self.a:
                self.dose += (tr - tc) * self._dose_rate(v)
            theta_ss = self._aging_factor() * float(d.rise_K(v))
            if self.lag is not None:
                times = np.concatenate([_DWELL_FRACTIONS * tm["dwell"][i], [tr - tc, tn - tc]])
                th = self.lag.advance(theta_ss, times)
                th_samples, th_read = th[:-1], float(th[-2])
            else:
                times = np.array([tr - tc])
                th_samples, th_read = np.array([theta_ss]), theta_ss
            th_in = th_samples + ambient(tc + times[: len(th_samples)])
            xs = d.equivalent_voltage(th_in)
            pts = _turning_points(self.x_in, np.asarray(xs))
            # map turning points back to temperatures (eq is monotone): move in temperature
            for x in pts:
                self._move_to_theta(float(d.kelvin_per_V2 * x * x))
            P_out[i] = self._phase_out()
            v_th[i] = float(d.equivalent_voltage(th_read))
            theta_rd[i] = th_read + float(ambient(tr))
            if "heater_aging" in self.a:
                self.dose += (tn - tr) * self._dose_rate(v)
        return {"P": P_out, "v_th": v_th, "theta": theta_rd}

    def rest(self, duration_s: float, amb0: float) -> tuple[float, float]:
        """Heater off for ``duration_s`` (0: the long rest before the first run); returns (phase, v_thermal)."""
        if not self.temp:
            self._move(self.d.v_min_V)
            return self._phase_out(), 0.0
        th = 0.0
        if self.lag is not None and duration_s > 0:
            th = float(self.lag.advance(0.0, np.array([duration_s]))[0])
        x = float(self.d.equivalent_voltage(th + amb0))
        self._move_to_theta(float(self.d.kelvin_per_V2 * x * x))
        return self._phase_out(), float(self.d.equivalent_voltage(th))


# ----------------------------------------------------------------------------- anhysteretic parts

def _joule(form: dict, s: float, prof: _Profile, device: BaseDevice, v_th: np.ndarray) -> np.ndarray:
    def h(r):
        a, b = form["tcr_saturation"], form["cte_slope"]
        T = r * r * (1.0 + a) / (1.0 + a * r * r)
        return T * (1.0 + b * T) / (1.0 + b) - r

    rr = np.linspace(0.0, 1.0, 501)
    hmax = max(float(np.max(np.abs(h(rr)))), 1e-12)
    sgn = 1.0 if device.thermal_um_per_V >= 0 else -1.0
    r = np.asarray(v_th, float) / device.v_max_V
    return s * form["peak_frac_at_1"] * prof.swing_um * sgn * h(r) / hmax


def _reversible(form: dict, s: float, prof: _Profile, device: BaseDevice, v: np.ndarray,
                theta: np.ndarray) -> np.ndarray:
    kind = form["kind"]
    th_max = float(device.rise_K(device.v_max_V))
    th_c = 0.5 * (device.transition_heating_C + device.transition_cooling_C) - device.ambient_C \
        + form.get("center_offset_K", 0.0)

    def f(vv, tt):
        r = np.asarray(vv, float) / device.v_max_V
        t = np.asarray(tt, float)
        if kind == "structural_sigmoid":
            return np.tanh((t - th_c) / form["width_K"])
        if kind == "softening_bump":
            return np.exp(-0.5 * ((t - th_c) / form["width_K"]) ** 2)
        if kind == "electrostatic":
            return r * r / (1.0 - form["pull_in"] * np.minimum(r * r, 1.5))
        if kind == "geometric":
            return np.power(np.maximum(t, 0.0) / th_max, form["power"])
        var = r if form["variable"] == "voltage" else np.sqrt(np.maximum(t, 0.0) / th_max)
        x = 2.0 * var - 1.0
        p2 = 0.5 * (3 * x * x - 1)
        p3 = 0.5 * (5 * x ** 3 - 3 * x)
        p4 = (35 * x ** 4 - 30 * x * x + 3) / 8.0
        c = form["coef"]
        return c[0] * p2 + c[1] * p3 + c[2] * p4

    vg = np.linspace(0.0, device.v_max_V, 601)
    tg = device.rise_K(vg)
    base0 = f(0.0, 0.0)
    scale = max(float(np.max(np.abs(f(vg, tg) - base0))), 1e-12)
    return s * form["peak_frac_at_1"] * prof.swing_um * form["sign"] * (f(v, theta) - base0) / scale


# ----------------------------------------------------------------------------- public entry

def simulate(device: BaseDevice, schedules, effects, seed: int, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md); returns one dict per run with t_s, v_V, y_um and dwell_s."""
    known = set(LIBRARY) | set(OUTSIDE)
    active: dict = {}
    for family, form, strength in effects:
        if family not in known:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not s >= 0.0:
            raise ValueError(f"strength must be >= 0, got {strength!r}")
        if family in active:
            raise ValueError(f"mechanism {family!r} given twice")
        if s > 0.0:
            active[family] = (form, s)

    sess = _Session(device, active, seed)
    prof = sess.prof
    t_rng = stream(seed, "timing")
    gap_s = float(t_rng.uniform(540.0, 660.0))
    timings = [_timing(sch, stream(seed, "timing", r)) for r, sch in enumerate(schedules)]

    def path(family: str, r: int, t_end: float):
        form, _ = active[family]
        return drift_path(form["components"], t_end, (seed, family, r))

    amb_paths = []
    for r, tm in enumerate(timings):
        if "ambient_drift" in active:
            form, s = active["ambient_drift"]
            g, val = path("ambient_drift", r, tm["t_end"] + 1.0)
            amb_paths.append((g, s * form["rms_K_at_1"] * val))
        else:
            amb_paths.append(None)

    # ---- film and deflection, run by run (session time runs on through the gap)
    runs = []
    t0 = 0.0
    rest_before = []
    for r, tm in enumerate(timings):
        amb0 = float(np.interp(0.0, *amb_paths[r])) if amb_paths[r] is not None else 0.0
        if r == 0:
            P_rest, vth_rest = sess.rest(0.0, amb0)
        else:
            if "heater_aging" in active:
                sess.dose += gap_s * sess._dose_rate(0.0)
            P_rest, vth_rest = sess.rest(gap_s, amb0)
            t0 += gap_s
        film = sess.run_film(tm, amb_paths[r])
        film["t0"] = t0
        runs.append(film)
        rest_before.append((P_rest, vth_rest))
        t0 += tm["t_end"]

    def deflection(P, v_th, v, theta):
        u = device.output(P, v_th)
        if "joule_power" in active:
            form, s = active["joule_power"]
            u = u + _joule(form, s, prof, device, v_th)
        if "reversible" in active:
            form, s = active["reversible"]
            u = u + _reversible(form, s, prof, device, v, theta)
        return u

    for r, (film, tm) in enumerate(zip(runs, timings)):
        film["u"] = np.asarray(deflection(film["P"], film["v_th"], tm["v"], film["theta"]), float)
        P_rest, vth_rest = rest_before[r]
        th_rest = float(device.rise_K(vth_rest))
        film["u_rest"] = float(deflection(np.array([P_rest]), np.array([vth_rest]), np.zeros(1),
                                          np.array([th_rest]))[0])
        film["P_rest"] = P_rest

    # ---- mechanics: creep (session-wide), first-point settling, mount backlash
    if "creep" in active:
        form, s = active["creep"]
        key_now, key_rest = ("u", "u_rest") if form["driver"] == "total" else ("P", "P_rest")
        c = form["sign"] * s * form["fraction_at_1"]
        ref = runs[0][key_rest] if runs else 0.0
        units = CreepUnits(np.asarray(form["spectrum_tau_s"]), np.asarray(form["spectrum_weight"]),
                           form["eyring"] / max(prof.swing_um, 1e-12), form["rate_asym"])
        for r, (film, tm) in enumerate(zip(runs, timings)):
            drv = np.asarray(film[key_now], float) - ref
            if r > 0:   # the rest between the runs (heater off)
                units.advance(film[key_rest] - ref, gap_s)
            cr = np.empty(len(drv))
            for i in range(len(drv)):
                units.advance(drv[i], tm["t_read"][i] - tm["t_cmd"][i])
                cr[i] = units.value()
                units.advance(drv[i], tm["t_next"][i] - tm["t_read"][i])
            film["u"] = film["u"] + c * cr

    if "first_point" in active:
        form, s = active["first_point"]
        A = s * form["amp_frac_at_1"] * prof.swing_um
        vmax = device.v_max_V
        for film, tm in zip(runs, timings):
            v = tm["v"]
            n = len(v)
            off = np.zeros(n)
            prev_dir = -1.0                # the heater was last lowered (switched off)
            prev_v = 0.0
            for i in range(n):
                dv = float(v[i]) - prev_v
                prev_v = float(v[i])
                if dv == 0.0:
                    continue
                dr = 1.0 if dv > 0 else -1.0
                if dr != prev_dir:
                    x = abs(dv) / vmax
                    law = form["size_law"]
                    g = {"const": 1.0, "linear": x, "sqrt": math.sqrt(x),
                         "saturating": -math.expm1(-abs(dv) / form["v0_V"]) / -math.expm1(-vmax / form["v0_V"])}[law]
                    a = A * form["sign"] * dr * (1.0 + form["asym"] * dr) * g
                    k = 0
                    while i + k < n and (k == 0 or abs(a) * form["linger"] ** k > 1e-9 * A):
                        off[i + k] += a * form["linger"] ** k
                        k += 1
                        if form["linger"] == 0.0:
                            break
                prev_dir = dr
            film["u"] = film["u"] + off

    if "backlash" in active:
        form, s = active["backlash"]
        A = s * form["halfwidth_frac_at_1"] * prof.swing_um
        plays = form["plays"]
        r_up = np.array([A * p["width"] * (1.0 + p["asym"]) for p in plays])
        r_dn = np.array([A * p["width"] * (1.0 - p["asym"]) for p in plays])
        wts = np.array([p["weight"] for p in plays])
        m = runs[0]["u_rest"] + r_dn if runs else None
        for r, film in enumerate(runs):
            m = np.maximum(film["u_rest"] - r_up, np.minimum(film["u_rest"] + r_dn, m))
            out = np.empty(len(film["u"]))
            for i, u in enumerate(film["u"]):
                m = np.maximum(u - r_up, np.minimum(u + r_dn, m))
                out[i] = float(wts @ m)
            film["u"] = out

    # ---- sensor and logger
    resid = None
    if "sensor_nonlinearity" in active:
        form, s = active["sensor_nonlinearity"]
        resid = sensor_residual(form, prof.u_lo, prof.u_hi)
    out = []
    for r, (film, tm) in enumerate(zip(runs, timings)):
        y = film["u"]
        if resid is not None:
            form, s = active["sensor_nonlinearity"]
            y = y + s * form["peak_frac_at_1"] * prof.swing_um * resid(y)
        if "gain_drift" in active:
            form, s = active["gain_drift"]
            g, val = path("gain_drift", r, tm["t_end"] + 1.0)
            y = y * (1.0 + s * form["rms_rel_at_1"] * np.interp(tm["t_read"], g, val))
        if "baseline_drift" in active:
            form, s = active["baseline_drift"]
            g, val = path("baseline_drift", r, tm["t_end"] + 1.0)
            y = y + s * form["rms_frac_at_1"] * prof.swing_um * np.interp(tm["t_read"], g, val)
        y = np.array(y, dtype=float, copy=True)
        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * stream(seed, "noise", r).standard_normal(len(y))
        out.append({
            "t_s": tm["t_read"].copy(),
            "v_V": tm["v"].copy(),
            "y_um": y,
            "dwell_s": tm["t_read"] - tm["t_cmd"],
        })
    return out
