"""One session: the base device plus the requested mechanisms, composed in physical order.

temperature (ambient_drift, thermal_lag) -> film (interaction, accommodation,
hysteresis) -> deflection (reversible, joule_power, creep, first_point,
backlash) -> sensor (sensor_nonlinearity, psd_reflectance, gain_drift,
baseline_drift) -> logger (noise, time stamps).
"""

from __future__ import annotations

import numpy as np

from . import drift, output, thermal, timing
from .film import Accommodation, Film
from .forms import LIBRARY, OUTSIDE
from .streams import stream

#: Ambient drift of the film at strength 1, per nominal unit of the drift path (K per K of width).
AMBIENT_K_PER_WIDTH = 0.05
#: Mean-field shift at strength 1 between the insulating and the metallic film (K per K of width).
INTERACTION_K_PER_WIDTH = 0.06
#: The interaction's loop gain never exceeds this (no avalanches).
MAX_LOOP_GAIN = 0.6


class Scales:
    """Device-dependent scales that turn a form and a strength into physical sizes."""

    def __init__(self, device):
        self.S = device.phase_swing_um
        self.swing = 2.0 * self.S
        self.k = device.kelvin_per_V2
        self.v_max = device.v_max_V
        self.width_C = device.transition_width_C
        theta = device.thermal_um_per_V * device.v_max_V
        self.u_lo = device.bias_um + min(0.0, theta) - self.S
        self.u_hi = device.bias_um + max(0.0, theta) + self.S
        self.u_absmax = max(abs(self.u_lo), abs(self.u_hi))
        mid_C = 0.5 * (device.transition_heating_C + device.transition_cooling_C)
        self.v_transition = float(device.equivalent_voltage(mid_C - device.ambient_C))


def _eqv(k: float, rise):
    return np.sqrt(np.maximum(rise, 0.0) / k)


def _turning(prev: float, seq: np.ndarray) -> list[int]:
    """Indices of ``seq`` whose values change a rate-independent memory: its reversals and its end."""
    full = np.concatenate([[prev], seq])
    d = np.diff(full)
    d = np.where(np.abs(d) > 0, np.sign(d), 0.0)
    keep = []
    last = 0.0
    for j in range(seq.size - 1):
        if d[j] != 0.0:
            last = d[j]
        nxt = d[j + 1]
        if last != 0.0 and nxt != 0.0 and nxt != last:
            keep.append(j)
    keep.append(seq.size - 1)
    return keep


def _max_slope_K(device, sc: Scales) -> float:
    """The steepest slope of the phase part versus the film's rise on the major loop (um / K)."""
    xs = np.linspace(device.v_min_V, device.v_max_V, 151)
    h = device.hysteresis()
    up = np.array([h.peek(x) for x in xs])
    h.move(device.v_max_V)
    down = np.array([h.peek(x) for x in xs])
    rise = sc.k * xs**2
    slope = max(np.max(np.abs(np.diff(up) / np.diff(rise))), np.max(np.abs(np.diff(down) / np.diff(rise))))
    return float(max(slope, 1e-12))


def _reversible(form: dict, strength: float, sc: Scales, x: np.ndarray) -> np.ndarray:
    amp = strength * output.NOMINAL * sc.swing * form["gain"] * form["sign"]
    xc = sc.v_transition + form["centre_offset_V"]
    w = form["width_V"]
    kind = form["kind"]
    if kind == "sigmoid":
        g = np.tanh((x - xc) / w)
    elif kind == "bump":
        g = np.exp(-(((x - xc) / w) ** 2))
    elif kind == "softplus":  # a reversible strain that sets in above the transition and then grows
        g = w * np.logaddexp(0.0, (x - xc) / w) / (sc.v_max - xc + w)
    else:
        g = (x / sc.v_max) ** form["power"]
    return amp * g


def _joule(form: dict, strength: float, sc: Scales, theta: float, v_th: np.ndarray) -> np.ndarray:
    """Deflection (um) the bimorph term gains when it follows the rise (and alpha(T)), not the voltage."""
    beta = form["tempco"]

    def f_of(v):
        q = (v / sc.v_max) ** 2
        return sc.v_max * (q + beta * q * q / 2.0) / (1.0 + beta / 2.0)

    vv = np.linspace(0.0, sc.v_max, 121)
    dev = float(np.max(np.abs(theta * (f_of(vv) - vv))))
    lam = strength * output.NOMINAL * sc.swing * form["gain"] / max(dev, 1e-12)
    return lam * theta * (f_of(v_th) - v_th)


def _drift_at(form: dict, seed: int, family: str, end_s: float, times: np.ndarray) -> np.ndarray:
    t, y = drift.path(form, stream(seed, family), end_s)
    return np.interp(times, t, y)


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md and README.md)."""
    eff: dict[str, tuple[dict, float]] = {}
    for family, form, strength in effects:
        if family not in LIBRARY + OUTSIDE:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not s >= 0.0:
            raise ValueError(f"strength of {family} must be >= 0, got {strength!r}")
        if family in eff:
            raise ValueError(f"mechanism {family!r} given twice")
        if s > 0.0:
            eff[family] = (form, s)

    tl = timing.build(schedules)
    sc = Scales(device)
    n = tl.v.size
    k = sc.k

    # ---- temperature ----------------------------------------------------------------
    lag = None
    if "thermal_lag" in eff:
        form, s = eff["thermal_lag"]
        lag = thermal.ThermalLag(form, s, k, sc.v_max, sc.width_C)
    fr = thermal.FRACTIONS if lag is not None else np.array([0.0, 1.0])
    sample_t = tl.a[:, None] + fr[None, :] * (tl.r - tl.a)[:, None]
    amb = None
    if "ambient_drift" in eff:
        form, s = eff["ambient_drift"]
        scale = s * AMBIENT_K_PER_WIDTH * sc.width_C * form["gain"]
        amb = scale * _drift_at(form, seed, "ambient_drift", tl.end_s, sample_t.ravel()).reshape(sample_t.shape)

    # ---- film -----------------------------------------------------------------------
    inter = None
    if "interaction" in eff:
        form, s = eff["interaction"]
        g1 = INTERACTION_K_PER_WIDTH * sc.width_C * form["gain"]
        gmax = MAX_LOOP_GAIN * sc.S / _max_slope_K(device, sc)
        gamma = form["sign"] * gmax * np.tanh(s * g1 / gmax)
        inter = (float(gamma), -sc.S if form["reference"] == "insulating" else 0.0)
    acc = None
    if "accommodation" in eff:
        form, s = eff["accommodation"]
        acc = Accommodation(form, s, sc.width_C, device)
    film = Film(device, inter, acc)

    phase = np.empty(n)
    d_read = np.zeros(n)      # film rise off the heater's steady state at the reading (K), w/o interaction
    heat_read = np.zeros(n)   # heater-driven part of that (K): what the bimorph term follows
    last_d = 0.0
    for i in range(n):
        if tl.fresh[i]:
            film.reset()
            last_d = 0.0
        v = tl.v[i]
        kv2 = k * v * v
        if lag is None and amb is None:
            film.drive(v, 0.0)
        else:
            heat = lag.segment(kv2, tl.a[i], tl.r[i], tl.nxt[i]) if lag is not None else np.zeros(fr.size)
            d = heat + amb[i] if amb is not None else heat
            # The hysterons only remember the reversals of their input: apply those and the end.
            seq = kv2 + d
            prev = tl.v[i - 1] if i > 0 else 0.0
            for j in _turning(k * prev * prev + last_d, seq):
                film.drive(v, float(d[j]))
            last_d = float(d[-1])
            d_read[i] = last_d
            heat_read[i] = float(heat[-1])
        phase[i] = film.value()

    # ---- deflection -----------------------------------------------------------------
    v_th = tl.v if lag is None else _eqv(k, k * tl.v**2 + heat_read)
    u = np.array([device.output(p, vt) for p, vt in zip(phase, v_th)])
    if "reversible" in eff:
        form, s = eff["reversible"]
        x_in = tl.v if form["input"] == "heater" else np.where(d_read == 0.0, tl.v, _eqv(k, k * tl.v**2 + d_read))
        u = u + _reversible(form, s, sc, x_in)
    if "joule_power" in eff:
        form, s = eff["joule_power"]
        u = u + _joule(form, s, sc, device.thermal_um_per_V, v_th)
    if "creep" in eff:
        form, s = eff["creep"]
        p0 = device.hysteresis().value()
        u0 = device.output(p0, 0.0)
        if "reversible" in eff:
            u0 += float(_reversible(eff["reversible"][0], eff["reversible"][1], sc, np.array([0.0]))[0])
        source = form["w_phase"] * phase + form["w_rest"] * (u - phase)
        source0 = form["w_phase"] * p0 + form["w_rest"] * (u0 - p0)
        u = u + output.creep(form, s, sc.swing, tl.a, tl.r, tl.nxt, source, source0)
    if "first_point" in eff:
        form, s = eff["first_point"]
        u = u + output.first_point(form, s, sc.swing, tl.v, sc.v_max)
    if "backlash" in eff:
        form, s = eff["backlash"]
        u = output.backlash(form, s, sc.swing, u)

    # ---- sensor ---------------------------------------------------------------------
    y = u
    if "sensor_nonlinearity" in eff:
        form, s = eff["sensor_nonlinearity"]
        c, length1 = output.nonlinearity_scale(form, sc.swing, sc.u_lo, sc.u_hi)
        y = output.sensor_nonlinearity(form, s, c, length1, y)
    if "psd_reflectance" in eff:
        form, s = eff["psd_reflectance"]
        y = y * output.psd_reflectance(form, s, sc.swing, sc.u_absmax, (phase + sc.S) / sc.swing)
    if "gain_drift" in eff:
        form, s = eff["gain_drift"]
        eps1 = output.NOMINAL * sc.swing * form["gain"] / sc.u_absmax
        y = y * (1.0 + s * eps1 * _drift_at(form, seed, "gain_drift", tl.end_s, tl.r))
    if "baseline_drift" in eff:
        form, s = eff["baseline_drift"]
        y = y + s * output.NOMINAL * sc.swing * form["gain"] * _drift_at(form, seed, "baseline_drift", tl.end_s, tl.r)

    # ---- logger ---------------------------------------------------------------------
    runs = []
    for kk, sched in enumerate(schedules):
        sel = tl.run == kk
        yk = np.array(y[sel], dtype=float)
        if noise_um is not None and noise_um > 0:
            yk = yk + float(noise_um) * stream(seed, "noise", kk).standard_normal(yk.size)
        runs.append({"t_s": tl.t_run[sel].copy(), "v_V": np.asarray(sched["v_V"], dtype=float).copy(), "y_um": yk})
    return runs
