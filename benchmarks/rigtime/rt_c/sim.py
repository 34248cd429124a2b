"""rt_c: forms and runs (see README.md)."""

from __future__ import annotations

import bisect
import math

import numpy as np
from scipy.optimize import brentq

from benchmarks.blind import base

from . import thermal
from .preisach import FastPhase

FORM_KIND = "rt_c/thermal-network/v1"
#: A mode below this share of the full-scale rise is taken as still (no sub-sampling).
_STILL = 1e-12
#: A mode above this share drives the sub-interval length inside a reading window.
_ACTIVE = 1e-9
#: Three-point Gauss-Legendre on [0, 1].
_GX = 0.5 + 0.5 * np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)])
_GW = np.array([5.0, 8.0, 5.0]) / 18.0


def draw_form(tau_s: float, rng: np.random.Generator, extras: bool = True) -> dict:
    tau_s = float(tau_s)
    net = thermal.draw_network(tau_s, rng)
    form = {
        "kind": FORM_KIND,
        "tau_s": tau_s,
        "v_full_scale_V": thermal.V_FULL_SCALE,
        "network": {k: net[k] for k in ("nodes", "links", "beam_mix", "time_scale_s")},
        "tau_modes_s": net["tau_modes_s"],
        "film_weights": net["film_weights"],
        "beam_weights": net["beam_weights"],
        "kappa_loss": float(rng.uniform(-0.25, 0.45)),
        "kappa_tcr": float(rng.uniform(0.0, 0.3)),
        "latent": float(rng.uniform(0.0, 0.3)),
        "extras": None,
    }
    if extras:
        frac = float(rng.uniform(3e-4, 1e-3))
        if rng.random() < 0.5:
            c0 = float(rng.uniform(-1.0, 1.0))
            c1 = float(rng.choice([-1.0, 1.0]) * (1.0 - abs(c0)) * rng.uniform(0.3, 1.0))
            form["extras"] = {
                "kind": "psd_drift", "fraction_of_swing": frac, "warmup_weight": c0,
                "warmup_s": thermal._loguniform(rng, 60.0, 1800.0), "wander_weight": c1,
                "wander_period_s": thermal._loguniform(rng, 300.0, 3600.0),
                "wander_phase_rad": float(rng.uniform(0.0, 2.0 * math.pi)),
            }
        else:
            form["extras"] = {"kind": "creep", "fraction_of_swing": frac,
                              "creep_tau_s": thermal._loguniform(rng, 5.0, 120.0)}
    return form


def instant_form() -> dict:
    """Infinitely fast thermal dynamics, no extras: the film is at steady state at once."""
    return {"kind": FORM_KIND, "tau_s": 0.0, "v_full_scale_V": thermal.V_FULL_SCALE,
            "network": None, "tau_modes_s": [], "film_weights": [], "beam_weights": [],
            "kappa_loss": 0.0, "kappa_tcr": 0.0, "latent": 0.0, "extras": None}


def settling_time_s(form: dict, tolerance: float) -> float:
    return thermal.settling_time_s(form, tolerance)


def _band(device, temp_C: float, full_rise: float) -> tuple[float, float]:
    rise = temp_C - device.ambient_C
    w = device.transition_width_C
    return (rise - w) / full_rise, (rise + w) / full_rise


def _overlap(lo: float, hi: float, band: tuple[float, float]) -> float:
    if hi - lo < 1e-12:
        return 1.0 if band[0] <= lo <= band[1] else 0.0
    return max(0.0, min(hi, band[1]) - max(lo, band[0])) / (hi - lo)


def _turning_points(c: list, taus: list, length: float) -> list[float]:
    """Zeros in (0, length) of ``sum c_i exp(-t / tau_i)`` (the film's rate, up to sign).

    Descartes' rule for exponential sums: the number of zeros is at most the
    number of sign changes of ``c`` ordered by rate (and of the same parity).
    """
    if length <= 0.0 or not c:
        return []
    scale = max(abs(x) for x in c)
    if scale == 0.0:
        return []
    cs = [x for _, x in sorted(zip(taus, c)) if abs(x) > 1e-13 * scale]
    changes = sum(1 for p, q in zip(cs[:-1], cs[1:]) if (p > 0) != (q > 0))
    if changes == 0:
        return []
    f = lambda s: sum(a * math.exp(-s / q) for a, q in zip(c, taus))
    if changes == 1:
        f0, f1 = f(0.0), f(length)
        if f0 * f1 < 0:
            return [brentq(f, 0.0, length, xtol=1e-12 * max(1.0, length))]
        return []
    ta = np.asarray(taus)
    t = np.concatenate([[0.0], np.geomspace(ta.min() * 1e-3, length, 96)])
    t = t[t <= length]
    d = np.exp(-t[:, None] / ta) @ np.asarray(c)
    return [brentq(f, t[k], t[k + 1], xtol=1e-12 * max(1.0, t[k + 1]))
            for k in np.nonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)[0]]


class _Film:
    """The film's rise ``T(t) = u + sum w_i r_i exp(-t / tau_i)`` (V^2) during one set-point."""

    def __init__(self, u, w, r, taus, walls_T):
        self.u = u
        self.c = [a * b for a, b in zip(w, r)]
        self.taus = taus
        self.walls_T = walls_T          # the grid walls as rises (V^2), increasing

    def T(self, t: float) -> float:
        return self.u + sum(c * math.exp(-t / q) for c, q in zip(self.c, self.taus))

    def dT(self, t: float) -> float:
        return -sum(c / q * math.exp(-t / q) for c, q in zip(self.c, self.taus))

    def crossing(self, t0: float, t1: float, T0: float, T1: float, target: float) -> float:
        """The time in [t0, t1] where the (monotone) rise passes ``target`` (safeguarded Newton)."""
        lo, hi = t0, t1
        inc = T1 > T0
        t = t0 + (t1 - t0) * (target - T0) / (T1 - T0)
        for _ in range(40):
            f = self.T(t) - target
            if (f < 0) == inc:
                lo = t
            else:
                hi = t
            if abs(f) <= 1e-13 * max(1.0, abs(target)) or hi - lo <= 1e-13 * max(1.0, t1):
                return t
            d = self.dT(t)
            tn = t - f / d if d != 0.0 else 0.5 * (lo + hi)
            t = tn if lo < tn < hi else 0.5 * (lo + hi)
        return t

    def splits(self, t0: float, t1: float) -> list[float]:
        """Times in (t0, t1) where the film crosses a grid wall (the piece is monotone)."""
        T0, T1 = self.T(t0), self.T(t1)
        lo, hi = (T0, T1) if T0 < T1 else (T1, T0)
        W = self.walls_T
        i = bisect.bisect_right(W, lo)
        j = bisect.bisect_left(W, hi)
        if j <= i:
            return []
        ws = W[i:j] if T1 > T0 else W[i:j][::-1]
        return [self.crossing(t0, t1, T0, T1, w) for w in ws]


def _window_nodes(a: float, b: float, amp: list, taus: list, film: "_Film",
                  turns: list) -> tuple[list[float], list[float]]:
    """Quadrature nodes/weights (weights sum to 1) of the average over [a, b].

    A still window takes its midpoint.  Otherwise the window is cut at the
    film's turning points, at every grid wall it crosses (the phase part is
    smooth between walls) and into steps no longer than twice the fastest
    mode still above _ACTIVE; each piece takes 3-point Gauss-Legendre.
    """
    if b <= a:
        return [a], [1.0]
    live_amp = [p * math.exp(-a / q) for p, q in zip(amp, taus)]
    if max(live_amp, default=0.0) <= _STILL:
        return [0.5 * (a + b)], [1.0]
    cuts = [a]
    t = a
    width = b - a
    while t < b - 1e-12 * width:
        step = b - t
        for p, q in zip(amp, taus):
            if 2.0 * q < step and p * math.exp(-t / q) > _ACTIVE:
                step = 2.0 * q
        if t + 1.25 * step >= b:
            step = b - t
        t += step
        cuts.append(t)
    cuts[-1] = b
    cuts = sorted(set(cuts + [x for x in turns if a < x < b]))
    pieces = [cuts[0]]
    for t0, t1 in zip(cuts[:-1], cuts[1:]):
        pieces.extend(film.splits(t0, t1))
        pieces.append(t1)
    nodes: list[float] = []
    weights: list[float] = []
    gx0, gx1, gx2 = _GX.tolist()
    gw0, gw1, gw2 = _GW.tolist()
    for t0, t1 in zip(pieces[:-1], pieces[1:]):
        step = t1 - t0
        if step <= 0.0:
            continue
        nodes.extend((t0 + step * gx0, t0 + step * gx1, t0 + step * gx2))
        fw = step / width
        weights.extend((fw * gw0, fw * gw1, fw * gw2))
    return nodes, weights


def _drift(ex: dict, amp: float, t: np.ndarray) -> np.ndarray:
    return amp * (ex["warmup_weight"] * (1.0 - np.exp(-t / ex["warmup_s"]))
                  + ex["wander_weight"] * np.sin(2.0 * math.pi * t / ex["wander_period_s"] + ex["wander_phase_rad"]))


def simulate(device, schedule: dict, form: dict, seed: int, noise_um: float | None) -> dict:
    v = np.asarray(schedule["v_V"], dtype=float).ravel()
    n = v.size
    dwell = np.broadcast_to(np.asarray(schedule["dwell_s"], dtype=float), (n,)).tolist()
    K = np.broadcast_to(np.asarray(schedule["readings"], dtype=int), (n,))
    meas = np.broadcast_to(np.asarray(schedule["measured"], dtype=bool), (n,))
    rs = float(schedule["reading_s"])
    Kl, ml, vl = K.tolist(), meas.tolist(), v.tolist()

    taus0 = np.asarray(form["tau_modes_s"], dtype=float)
    wf = np.asarray(form["film_weights"], dtype=float)
    wb = np.asarray(form["beam_weights"], dtype=float)
    m = taus0.size
    taus0l, wfl = taus0.tolist(), wf.tolist()
    full = form.get("v_full_scale_V", thermal.V_FULL_SCALE) ** 2          # V^2
    full_rise = device.kelvin_per_V2 * full
    band_heat = _band(device, device.transition_heating_C, full_rise)
    band_cool = _band(device, device.transition_cooling_C, full_rise)
    wmaxl = (np.maximum(np.abs(wf), np.abs(wb)) / full).tolist()

    ex = form.get("extras")
    swing = device.phase_swing_um
    drift_amp = creep_c = creep_tau = 0.0
    if ex is not None and ex["kind"] == "psd_drift":
        drift_amp = ex["fraction_of_swing"] * swing
    elif ex is not None and ex["kind"] == "creep":
        creep_c = ex["fraction_of_swing"] * swing / (2.0 * swing + abs(device.thermal_um_per_V) * device.v_max_V)
        creep_tau = ex["creep_tau_s"]
    bias, th = device.bias_um, device.thermal_um_per_V

    fp = FastPhase(device)
    # where the phase part may kink: grid walls and memory corners, kept only where the film has
    # grains (a kink where the density is nil is no kink)
    D = np.asarray(device.grid.density_matrix(np.asarray(device.density_um, dtype=float)))
    band = (D.sum(axis=0) + D.sum(axis=1)) / max(float(D.sum()), 1e-300)
    near = np.convolve(np.concatenate([[0.0], band, [0.0]]), np.ones(3), mode="valid")
    near = (near > 1e-10).tolist()                       # per band: it or a neighbour has grains
    walls = np.asarray(device.grid.walls, dtype=float)
    L = int(device.levels)
    walls_T = [float(walls[j]) ** 2 for j in range(L + 1)
               if walls[j] > 0.0 and (near[max(j - 1, 0)] or near[min(j, L - 1)])]
    h, vmin = float(device.grid.step), float(device.v_min_V)

    def _kink(xv: float) -> bool:
        c = (xv - vmin) / h
        return 0.0 <= c <= L and near[min(max(int(c), 0), L - 1)]
    move = fp.move
    out_y = np.full(n, np.nan)
    out_t = np.zeros(n)
    r = [0.0] * m                     # modal residuals (V^2): state minus the current target
    u_prev = 0.0                      # the previous target v^2 (the run starts at 0 V, settled)
    t0 = 0.0
    creep = [None, 0.0, 0.0]          # low-passed deflection, the deflection held, its time

    def _creep(y: float, ta: float) -> float:
        s, uh, th_ = creep
        s = y if s is None else uh + (s - uh) * math.exp(-(ta - th_) / creep_tau)
        creep[0], creep[1], creep[2] = s, y, ta
        return y - creep_c * (y - s)

    for k in range(n):
        vk = vl[k]
        u = vk * vk
        du = u_prev - u
        r = [ri + du for ri in r]
        u_prev = u
        if m:
            lvl_s = (u + sum(a * b for a, b in zip(wfl, r))) / full
            lvl_t = u / full
            lo, hi = (lvl_s, lvl_t) if lvl_s < lvl_t else (lvl_t, lvl_s)
            ov = _overlap(lo, hi, band_heat if lvl_t >= lvl_s else band_cool)
            g = thermal.stretch(form, lvl_s, lvl_t, ov)
            taus = [q * g for q in taus0l]
        else:
            taus = []
        Kk = Kl[k]
        take = ml[k] and Kk > 0
        length = dwell[k] + (Kk * rs if take else 0.0)
        ampl = [abs(a) * b for a, b in zip(r, wmaxl)]
        if max(ampl, default=0.0) <= _STILL:
            # the film is still: one move; extras averaged at the windows' midpoints
            x = math.sqrt(max(u + sum(a * b for a, b in zip(wfl, r)), 0.0)) if m else vk
            vth = math.sqrt(max(u + sum(a * b for a, b in zip(wb.tolist(), r)), 0.0)) if m else vk
            y0 = bias + th * vth + move(x)
            if take:
                if drift_amp or creep_c:
                    tm = t0 + dwell[k] + (np.arange(Kk) + 0.5) * rs
                    ys = y0 + (_drift(ex, drift_amp, tm) if drift_amp else 0.0)
                    if creep_c:
                        ys = [_creep(float(yy), float(ta)) for yy, ta in zip(np.broadcast_to(ys, tm.shape), tm)]
                    out_y[k] = float(np.mean(ys))
                else:
                    out_y[k] = y0
            if creep_c:
                _creep(y0, t0 + length)
            if m:
                r = [ri * math.exp(-length / q) for ri, q in zip(r, taus)]
            out_t[k] = t0 + length
            t0 += length
            continue
        # events: (time, weight); weight 0 = only move the hysteresis
        times: list[float] = []
        wts: list[float] = []
        turns = _turning_points([a * b / q for a, b, q in zip(wfl, r, taus)], taus, length)
        if take:
            # the phase part is smooth in x except at grid walls and at the memory's corners:
            # those at the start and the turning points to come (a later sweep may wipe them out)
            film = _Film(u, wfl, r, taus, [])
            corners = fp.corners_V() + [math.sqrt(max(film.T(t), 0.0)) for t in turns]
            kinks = walls_T + [c * c for c in corners if _kink(c)]
            film.walls_T = sorted(set(kinks))
            for j in range(Kk):
                a = dwell[k] + j * rs
                nd, wt = _window_nodes(a, a + rs, ampl, taus, film, turns)
                times.extend(nd)
                wts.extend(x / Kk for x in wt)
        extra_t = [length] + turns
        times.extend(extra_t)
        wts.extend([0.0] * len(extra_t))
        ev = sorted(zip(times, wts))
        tt = np.fromiter((e[0] for e in ev), float, len(ev))
        ww = np.fromiter((e[1] for e in ev), float, len(ev))
        ra, ta_ = np.asarray(r), np.asarray(taus)
        E = np.exp(-tt[:, None] / ta_) * ra
        x = np.sqrt(np.maximum(u + E @ wf, 0.0))
        lin = bias + th * np.sqrt(np.maximum(u + E @ wb, 0.0))
        r = (ra * np.exp(-length / ta_)).tolist()
        if drift_amp:
            lin = lin + _drift(ex, drift_amp, t0 + tt)
        acc = 0.0
        for xi, li, wi, ti in zip(x.tolist(), lin.tolist(), ww.tolist(), tt.tolist()):
            y = li + move(xi)
            if creep_c:
                y = _creep(y, t0 + ti)
            if wi:
                acc += wi * y
        if take:
            out_y[k] = acc
        out_t[k] = t0 + length
        t0 += length

    if noise_um is not None and noise_um > 0:
        rng = np.random.default_rng(np.random.SeedSequence([0x7C_2026, int(seed)]))
        counts = np.where(meas, K, 0)
        eps = rng.standard_normal(int(counts.sum())) * float(noise_um)
        sums = np.zeros(n)
        np.add.at(sums, np.repeat(np.arange(n), counts), eps)
        has = counts > 0
        out_y[has] += sums[has] / counts[has]
    return {"t_s": out_t, "v_V": v.copy(), "y_um": out_y}
