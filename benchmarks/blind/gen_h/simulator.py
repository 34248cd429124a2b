"""One session on one device: the rig's timing, the signal chain, the logger."""

from __future__ import annotations

import math

import numpy as np

from . import mechanisms as M
from ._streams import noise_stream, timing_stream
from .forms import LIBRARY, OUTSIDE
from .thermal import ThermalLag

#: The PSD's sampling period during a burst (s): the lab's DAQ reads at 500 Hz.
SAMPLE_PERIOD_S = 0.002

#: Where, within a dwell (fraction of the time to the reading), the film's path is sampled to
#: find the turning points of the hysterons' input (the first is the heater's step itself).
_REL = np.array([1e-5, 0.003, 0.01, 0.03, 0.06, 0.1, 0.17, 0.25, 0.35, 0.5, 0.7, 1.0])


class Timeline:
    """A run's timing, drawn from the run's own stream.

    ``t_change[n]``: the set-point change (s from the run's start); ``t_read[n]``: the time stamp
    of the averaged reading (the middle of the burst); ``t_end``: the end of the last burst;
    ``gap``: the heater-off time before this run (after the previous run's end).
    """

    def __init__(self, seed: int, run: int, dwell: np.ndarray, K: int) -> None:
        rng = timing_stream(seed, run)
        n = dwell.size
        self.gap = float(rng.uniform(540.0, 660.0))
        t0 = float(rng.uniform(0.2, 1.0))
        latency = rng.uniform(0.003, 0.030, n)  # command -> heater settled (DAQ/driver latency)
        hic_p = rng.random(n)
        hic_len = rng.uniform(0.05, 0.8, n)  # rare hiccups of the controlling computer
        overhead = rng.uniform(0.001, 0.015, n)  # logging between the burst and the next command
        hiccup = np.where(hic_p < 0.01, hic_len, 0.0)
        held = dwell + latency + hiccup
        burst = K * SAMPLE_PERIOD_S
        step = held + burst + overhead
        self.t_change = t0 + np.concatenate([[0.0], np.cumsum(step)[:-1]])[:n]
        self.t_read = self.t_change + held + 0.5 * (K - 1) * SAMPLE_PERIOD_S
        self.t_end = float(self.t_change[-1] + held[-1] + burst) if n else t0


def _turning(x0: float, xs) -> list[float]:
    """The turning points of the path ``xs`` starting from ``x0`` (Preisach memory needs only these)."""
    out: list[float] = []
    last, d = x0, 0
    for x in xs:
        dx = x - last
        if abs(dx) <= 1e-13:
            continue
        s = 1 if dx > 0 else -1
        if out and s == d:
            out[-1] = x
        else:
            out.append(x)
            d = s
        last = x
    return out


ALL = LIBRARY + OUTSIDE


def simulate(device, schedules, effects, seed, noise_um):
    """Simulate one session (see SPEC.md and README.md)."""
    active: dict[str, tuple[dict, float]] = {}
    for family, form, strength in effects:
        if family not in ALL:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not s >= 0.0 or not math.isfinite(s):
            raise ValueError(f"strength must be finite and >= 0, got {strength!r}")
        if s == 0.0:
            continue
        if family in active:
            raise ValueError(f"mechanism {family!r} given twice")
        active[family] = (form, s)

    ctx = M.DeviceContext(device) if active else None

    def make(name, cls):
        if name not in active:
            return None
        form, s = active[name]
        return cls(form, s, device, ctx)

    therm = ThermalLag(active["thermal_lag"][0], active["thermal_lag"][1], device) if "thermal_lag" in active else None
    amb = M.AmbientDrift(*active["ambient_drift"], seed) if "ambient_drift" in active else None
    inter = make("interaction", M.Interaction)
    acc = make("accommodation", M.Accommodation)
    joule = make("joule_power", M.JoulePower)
    rev = make("reversible", M.Reversible)
    creep = make("creep", M.Creep)
    back = make("backlash", M.Backlash)
    fp = make("first_point", M.FirstPoint)
    opt = make("optical_contrast", M.OpticalContrast)
    snl = make("sensor_nonlinearity", M.SensorNonlinearity)
    gain = M.SensorDrift("gain_drift", *active["gain_drift"], seed, ctx) if "gain_drift" in active else None
    base = M.SensorDrift("baseline_drift", *active["baseline_drift"], seed, ctx) if "baseline_drift" in active else None

    temperature = therm is not None or amb is not None
    S = float(device.phase_swing_um)
    u_rest = float(device.bias_um) - S  # the clean device at 0 V in negative saturation
    results = []
    prev_end_abs = 0.0
    for run, sched in enumerate(schedules):
        v_all = np.asarray(sched["v_V"], dtype=float).reshape(-1)
        dwell = np.asarray(sched["dwell_s"], dtype=float).reshape(-1)
        if dwell.size != v_all.size:
            raise ValueError("v_V and dwell_s differ in length")
        K = int(sched.get("readings", 1))
        tl = Timeline(seed, run, dwell, max(K, 1))
        start_abs = 0.0 if run == 0 else prev_end_abs + tl.gap
        n_pts = v_all.size
        if therm is not None and run > 0:  # heater off since the previous run's end
            therm.interval(0.0, np.array([tl.gap + tl.t_change[0]]))
        amb_c = amb_r = None
        if amb is not None:
            amb_c, amb_r = amb.run_path(run, tl.t_change, tl.t_read)
        gain_p = gain.run_path(run, tl.t_read) if gain is not None else None
        base_p = base.run_path(run, tl.t_read) if base is not None else None
        h = device.hysteresis()
        for m in (inter, acc, fp):
            if m is not None:
                m.begin_run()
        x_last = float(device.v_min_V)
        P = h.value() if (inter is not None or acc is not None or opt is not None) else -S
        y_out = np.empty(n_pts)
        for n in range(n_pts):
            v = float(v_all[n])
            if temperature:
                R = float(device.rise_K(v))
                rel_read = float(tl.t_read[n] - tl.t_change[n])
                if therm is not None:
                    t_next = tl.t_change[n + 1] if n + 1 < n_pts else tl.t_end
                    rel = np.append(_REL * rel_read, float(t_next - tl.t_change[n]))
                    th = therm.interval(R, rel)[:-1]
                    qs = _REL
                else:
                    qs = np.array([1e-5, 1.0])
                    th = np.full(2, R)
                if amb is not None:
                    th_x = th + amb_c[n] + (amb_r[n] - amb_c[n]) * qs
                else:
                    th_x = th
                xs = device.equivalent_voltage(th_x)
                xs = [float(x) for x in xs]
                v_th = float(device.equivalent_voltage(th[-1])) if therm is not None else v
            else:
                xs = [v]
                v_th = v
            pts = _turning(x_last, xs) or [xs[-1]]
            for p in pts:
                xe = inter.solve(h, p) if inter is not None else p
                P = h.move(xe)
                if inter is not None:
                    inter.P_last = P
                if acc is not None:
                    acc.move(xe, P)
            x_last = xs[-1]
            P_tot = P + acc.term(P) if acc is not None else P
            u = device.output(P_tot, joule.map(v_th) if joule is not None else v_th)
            if rev is not None:
                u += rev.term(v, xs[-1])
            y = u
            if creep is not None:
                creep.event(P_tot if creep.phase else u, start_abs + float(tl.t_change[n]))
                y = y + creep.offset(start_abs + float(tl.t_read[n]))
            if back is not None:
                y = back.move(y)
            if fp is not None:
                y = y + fp.offset(v, u)
            if opt is not None:
                y = opt.apply(y, P)
            if snl is not None:
                y = snl.apply(y)
            if gain_p is not None:
                y = y * (1.0 + gain_p[n])
            if base_p is not None:
                y = y + base_p[n]
            y_out[n] = y
        end_abs = start_abs + tl.t_end
        # heater off at the end of the run: the film returns to negative saturation
        if acc is not None:
            acc.end_run()
        if creep is not None:
            creep.event(-S if creep.phase else u_rest, end_abs)
        if back is not None:
            back.move(u_rest)
        prev_end_abs = end_abs
        if noise_um is not None and float(noise_um) > 0.0:
            y_out = y_out + float(noise_um) * noise_stream(seed, run).standard_normal(n_pts)
        results.append({
            "t_s": tl.t_read.copy(),
            "v_V": v_all.copy(),
            "y_um": y_out,
            "dwell_s": tl.t_read - tl.t_change,
        })
    return results
