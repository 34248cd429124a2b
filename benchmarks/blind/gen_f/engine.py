"""The session simulator: logger timing, heater drive, thermal paths, film, beam, mount, PSD.

The signal chain, in its physical order (every stage is skipped when its mechanisms are
absent, so that with no effect the base device is reproduced bit for bit):

1. logger        set-point change times, reading (burst) times        (seed stream "logger")
2. heater drive  commanded volts -> Joule power (heater_anneal)        rise_K(v) * power factor
3. thermal       fast beam + slow paths (thermal_lag), room/package temperature (ambient_drift)
4. film          Preisach hysterons feel the film temperature (as equivalent volts), with the
                 mean field (interaction) and weights that change with use (accommodation)
5. beam          bias + bimorph term (joule_power, lagging temperature) + phase
                 + anhysteretic part (reversible) + visco-elastic relaxation (creep)
6. mount         play in the optical lever's mount (backlash)
7. PSD           spot = deflection + zero wander (baseline_drift); lateral-effect
                 nonlinearity (sensor_nonlinearity); transimpedance/laser gain (gain_drift);
                 direction-reversal transient (first_point); Gaussian noise (seed stream "noise")
"""

from __future__ import annotations

import dataclasses
import zlib

import numpy as np
from scipy import special

from .. import base
from . import paths
from .forms import LIBRARY, OUTSIDE

#: Strength-1 constants (see README): each makes strength 1 about 1 % of the output swing (rms).
C_LAG = 1.6            # typical film-temperature error at a reading, in units of unit_K
LAG_MAX = 8.0          # ... and at most this many unit_K anywhere on the film's path
C_AMBIENT = 4.5        # peak-to-peak of the package temperature over a run, in unit_K
C_BASELINE = 0.018     # peak-to-peak of the PSD zero over a run, fraction of the swing
C_GAIN = 0.025        # peak-to-peak of the gain error times max|u|, fraction of the swing
C_JOULE = 0.015        # largest departure of the bimorph term from linear, fraction of the swing
C_NONLIN = 0.018       # largest departure of the PSD from linear over the range, fraction of swing
C_REVERSIBLE = 0.02    # amplitude of the anhysteretic term, fraction of the swing
C_INTERACTION = 0.09   # loop gain at strength 1 (small strengths: gain = C * strength)
G_MAX = 0.6            # loop gain never exceeds this (well below one: no avalanches)
C_FIRST = 0.015        # first-point offset, fraction of the swing
C_CREEP = 0.01         # creep under way at the readings (rms, clean changes), fraction of swing
C_BACKLASH = 0.01      # half-width of the play, fraction of the swing
C_ACCOMMODATION = {"amplitude": 0.03, "shift": 0.07, "width": 0.08, "sharpen": 0.15, "broaden": 0.3}
C_ANNEAL = 4.0         # shift of the transition by the end of a session, in unit_K

BURST_DT_S = 0.01      # the DAQ's sample interval within a burst (100 Hz)
ALL = LIBRARY + OUTSIDE
_THERMAL = ("thermal_lag", "ambient_drift", "heater_anneal")
_FILM = ("interaction", "accommodation")


def stream(seed: int, *keys: str) -> np.random.Generator:
    """The random stream of one purpose (a mechanism's name, "logger", "noise"...)."""
    entropy = [0x9E3779B9, int(seed) % (2 ** 63)] + [zlib.crc32(k.encode()) for k in keys]
    return np.random.default_rng(np.random.SeedSequence(entropy))


# --------------------------------------------------------------------------- device scales

@dataclasses.dataclass(frozen=True)
class Scales:
    swing: float      # range of the clean output over the major loop (um)
    u_lo: float
    u_hi: float
    amp: float        # half the phase swing (um)
    slope_V: float    # steepest d(phase)/dx on the major loop (um/V)
    slope_K: float    # steepest d(phase)/dT on the major loop (um/K)
    v_tr: float       # the middle of the transition (V)
    unit_K: float     # temperature shift moving the steepest point by 1 % of the swing (K)


def device_scales(device: base.BaseDevice) -> Scales:
    vs = np.linspace(device.v_min_V, device.v_max_V, 121)
    h = device.hysteresis()
    up = np.array([h.move(float(v)) for v in vs])
    dn = np.array([h.move(float(v)) for v in vs[::-1]])[::-1]
    thermal = device.bias_um + device.thermal_um_per_V * vs
    u = np.concatenate([thermal + up, thermal + dn])
    swing = float(np.ptp(u))
    vm = 0.5 * (vs[1:] + vs[:-1])
    s_up, s_dn = np.diff(up) / np.diff(vs), np.diff(dn) / np.diff(vs)
    dTdv = 2.0 * device.kelvin_per_V2 * np.maximum(vm, 0.3)
    slope_K = float(max(np.max(s_up / dTdv), np.max(s_dn / dTdv)))
    return Scales(swing=swing, u_lo=float(u.min()), u_hi=float(u.max()), amp=device.phase_swing_um,
                  slope_V=float(max(s_up.max(), s_dn.max())), slope_K=slope_K,
                  v_tr=float(0.5 * (vm[np.argmax(s_up)] + vm[np.argmax(s_dn)])),
                  unit_K=0.01 * swing / slope_K)


# --------------------------------------------------------------------------- logger timing

@dataclasses.dataclass
class Timeline:
    v: np.ndarray          # heater set-point of every segment (V)
    A: np.ndarray          # segment start: the set-point change (session s)
    B: np.ndarray          # segment end: the next change (session s)
    e: np.ndarray          # evaluation: the reading (mid-burst), or the end of a rest
    rest: np.ndarray       # True for the heater-off gaps between runs
    run_bounds: list       # (start, end) of every run (session s)
    run_index: list        # segment indices of every run's readings
    t_s: list              # logged time stamps of every run (run s)


def timeline(schedules: list[dict], seed: int) -> Timeline:
    """This lab's logger (see README): DAC write, dwell timer, trigger latency, 100 Hz burst."""
    rng = stream(seed, "logger")
    v_l, a_l, b_l, e_l, rest_l = [], [], [], [], []
    bounds, idx, stamps = [], [], []
    t, count = 0.0, 0
    for r, sch in enumerate(schedules):
        v = np.asarray(sch["v_V"], dtype=float)
        dwell = np.asarray(sch["dwell_s"], dtype=float)
        k = int(sch.get("readings", 1))
        n = v.size
        startup = float(rng.uniform(0.3, 1.5))
        latency = 0.002 + rng.exponential(0.006, n)
        overhead = 0.040 + rng.exponential(0.015, n)
        gap = float(rng.uniform(540.0, 720.0))
        burst = (k - 1) * BURST_DT_S
        run_start = t
        first = run_start + startup
        if r > 0:  # heater off since the previous run's end
            v_l.append(np.zeros(1)); a_l.append(np.array([prev_end])); b_l.append(np.array([first]))
            e_l.append(np.array([first])); rest_l.append(np.ones(1, bool)); count += 1
        durations = dwell + latency + burst + overhead
        starts = first + np.concatenate([[0.0], np.cumsum(durations)[:-1]])
        ev = starts + dwell + latency + 0.5 * burst
        v_l.append(v); a_l.append(starts); b_l.append(starts + durations); e_l.append(ev)
        rest_l.append(np.zeros(n, bool))
        idx.append(np.arange(count, count + n)); count += n
        prev_end = float(starts[-1] + durations[-1]) if n else first
        bounds.append((run_start, prev_end))
        stamps.append(np.round(ev - run_start, 3))
        t = prev_end + gap
    cat = (lambda xs: np.concatenate(xs) if xs else np.zeros(0))
    return Timeline(v=cat(v_l), A=cat(a_l), B=cat(b_l), e=cat(e_l), rest=cat(rest_l).astype(bool),
                    run_bounds=bounds, run_index=idx, t_s=stamps)


# --------------------------------------------------------------------------- helpers

def _cell_indices(device: base.BaseDevice):
    """The (alpha wall, beta wall) of every density cell, probed through the public Hysteresis.

    Chunks of cells get weights 2**i; moving up wall by wall from negative saturation (then down
    from positive saturation) flips exactly the cells of one alpha (beta) wall, whose weights
    add up to a number that names them.  Returns (a, b) or None if the decoding fails.
    """
    key = (device.levels, device.v_min_V, device.v_max_V)
    if key in _CELL_CACHE:
        return _CELL_CACHE[key]
    L, n = device.levels, device.density_um.size
    w = device.v_min_V + (device.v_max_V - device.v_min_V) * np.arange(L + 1) / L
    a_idx, b_idx = np.full(n, -1), np.full(n, -1)
    chunk = 30
    for start in range(0, n, chunk):
        cells = np.arange(start, min(start + chunk, n))
        dens = np.zeros(n)
        dens[cells] = 2.0 ** np.arange(cells.size)
        h = base.Hysteresis(dataclasses.replace(device, density_um=dens))
        prev = h.value()
        for a in range(1, L + 1):
            cur = h.move(float(w[a]))
            _decode(round((cur - prev) / 2.0), start, a_idx, a)
            prev = cur
        for b in range(L - 1, -1, -1):
            cur = h.move(float(w[b]))
            _decode(round((prev - cur) / 2.0), start, b_idx, b)
            prev = cur
    ok = (np.all(a_idx >= 1) and np.all(b_idx >= 0) and np.all(a_idx > b_idx)
          and len(set(zip(a_idx.tolist(), b_idx.tolist()))) == n)
    _CELL_CACHE[key] = (a_idx, b_idx) if ok else None
    return _CELL_CACHE[key]


def _decode(bits: int, start: int, out: np.ndarray, wall: int) -> None:
    i = 0
    while bits > 0:
        if bits & 1:
            out[start + i] = wall
        bits >>= 1
        i += 1


_CELL_CACHE: dict = {}


def _turning_points(x_prev: float, seq: np.ndarray) -> list[float]:
    """The extremes of a sampled path (after ``x_prev``) and its end: all the hysterons see."""
    s = np.concatenate([[x_prev], seq])
    d = np.diff(s)
    keep = np.abs(d) > 1e-12
    s = np.concatenate([[s[0]], s[1:][keep]])
    if s.size < 2:
        return [float(seq[-1])]
    d = np.diff(s)
    turn = np.nonzero(d[:-1] * d[1:] < 0)[0] + 1
    return [float(s[i]) for i in turn] + [float(s[-1])]


# --------------------------------------------------------------------------- the film

class Film:
    """Hysterons with, optionally, a mean field (interaction) and weights that change with use."""

    def __init__(self, device, scales, interaction=None, accommodation=None):
        self.device, self.scales = device, scales
        self.feel = interaction            # None or f(x, phi) -> x_eff
        self.acc = accommodation           # None or dict(dens1, lam)
        self.cycles = accommodation["prior"] if accommodation else 0.0
        self._p_last = None
        self._turn = None
        self._dir = 0
        self.reset()

    def reset(self):
        self.h0 = self.device.hysteresis()
        self.h1 = None
        if self.acc is not None and self.acc["dens1"] is not None:
            self.h1 = base.Hysteresis(dataclasses.replace(self.device, density_um=self.acc["dens1"]))
        self.min_eff = np.inf

    def _lam(self):
        return self.acc["lam"](self.cycles) if self.acc is not None else 0.0

    def _combine(self, p0, p1):
        if self.acc is None:
            return p0
        lam = self._lam()
        return p0 + lam * p1 if self.h1 is not None else p0 * (1.0 + lam)

    def value(self):
        return self._combine(self.h0.value(), self.h1.value() if self.h1 is not None else 0.0)

    def _peek(self, x):
        return self._combine(self.h0.peek(x), self.h1.peek(x) if self.h1 is not None else 0.0)

    def _solve(self, x):
        tol = 1e-10 * self.scales.amp
        f = (lambda p: self._peek(self.feel(x, p)) - p)
        p0 = self.value()
        g0 = f(p0)
        if abs(g0) < tol:
            return p0
        p1 = p0 + g0
        g1 = f(p1)
        for _ in range(60):
            if abs(g1) < tol:
                break
            den = g1 - g0
            p2 = p1 + g1 if den == 0.0 else p1 - g1 * (p1 - p0) / den
            if not np.isfinite(p2) or abs(p2) > 4.0 * self.scales.amp:
                p2 = p1 + g1
            p0, g0, p1 = p1, g1, p2
            g1 = f(p1)
        return p1

    def move(self, x: float) -> float:
        x_eff = float(self.feel(x, self._solve(x))) if self.feel is not None else x
        p0 = self.h0.move(x_eff)
        if self.h1 is not None:
            self.h1.move(x_eff)
        self.min_eff = min(self.min_eff, x_eff)
        if self.acc is not None:
            self._count(p0)
        return self.value() if self.acc is not None else p0

    def _count(self, p0):
        full = 4.0 * self.scales.amp
        if self._p_last is None:
            self._p_last, self._turn = -self.scales.amp, -self.scales.amp
        dp = p0 - self._p_last
        if self.acc["counting"] == "variation":
            self.cycles += abs(dp) / full
        elif abs(dp) > 1e-12:
            d = 1 if dp > 0 else -1
            if self._dir != 0 and d != self._dir:  # a half cycle ended at the last point
                half = abs(self._p_last - self._turn) / (0.5 * full)
                self.cycles += 0.5 * half ** self.acc["miner"]
                self._turn = self._p_last
            self._dir = d
        self._p_last = p0


def _accommodation_spec(device, scales, form, strength):
    pattern = form["pattern"]
    d0 = np.asarray(device.density_um, dtype=float)
    dens1 = None
    if pattern in ("shift", "width"):
        cells = _cell_indices(device)
        if cells is None:
            pattern = "amplitude"
        else:
            a, b = cells
            lookup = {(int(i), int(j)): k for k, (i, j) in enumerate(zip(a, b))}
            da, db = ((1, 1) if pattern == "shift" else (1, -1))
            if form["sign"] < 0:
                da, db = -da, -db
            nb = np.array([lookup.get((int(i) + da, int(j) + db), -1) for i, j in zip(a, b)])
            moved = np.where(nb >= 0, d0[np.maximum(nb, 0)], 0.0)
            dens1 = moved - d0
    if pattern == "sharpen":
        total = d0.sum()
        target = d0 ** 2 if form["sign"] > 0 else np.sqrt(np.maximum(d0, 0.0))
        dens1 = target * total / max(target.sum(), 1e-300) - d0
    sign = 1.0 if (pattern != "amplitude" or form["sign"] > 0) else -1.0
    key = "broaden" if (pattern == "sharpen" and form["sign"] < 0) else pattern
    lam_s = sign * strength * C_ACCOMMODATION[key]
    kin, n0, pw = form["kinetics"], form["n0_cycles"], form["power"]

    def h(n):
        z = max(n, 0.0) / n0
        return {"saturating": 1.0 - np.exp(-z), "log": np.log1p(z), "power": z ** pw}[kin]

    prior, ref = form["prior_cycles"], h(40.0)
    h_prior = h(prior)
    return {"dens1": dens1, "prior": prior, "counting": form["counting"], "miner": form["miner_exponent"],
            "lam": (lambda n: lam_s * (h(n) - h_prior) / ref)}


def _interaction_feel(device, scales, form, strength):
    gain = G_MAX * (1.0 - np.exp(-strength * C_INTERACTION / G_MAX))
    q = form["cubic"]
    ref = {"centre": 0.0, "insulating": -scales.amp, "metallic": scales.amp}[form["reference"]]
    span = scales.amp if form["reference"] == "centre" else 2.0 * scales.amp
    k = device.kelvin_per_V2
    if form["space"] == "voltage":
        c = form["sign"] * gain / scales.slope_V / (1.0 + 3.0 * abs(q))

        def feel(x, phi):
            m = (phi - ref) / span
            return x + c * span * (m + q * m ** 3)
    else:
        c = form["sign"] * gain / scales.slope_K / (1.0 + 3.0 * abs(q))

        def feel(x, phi):
            m = (phi - ref) / span
            return float(np.sqrt(max(k * x * x + c * span * (m + q * m ** 3), 0.0) / k))
    return feel


# --------------------------------------------------------------------------- thermal paths

def _lag_modes(form):
    kern = form["kernel"]
    if kern == "paths":
        taus, w = np.array(form["taus_s"], float), np.array(form["weights"], float)
    elif kern == "spread":
        z = np.linspace(-2.5, 2.5, 9)
        taus = form["tau_median_s"] * np.exp(form["sigma_ln"] * z)
        w = np.exp(-0.5 * z * z)
    else:
        odd = 2.0 * np.arange(1, 9) - 1.0
        taus, w = form["tau0_s"] / odd ** 2, 1.0 / odd ** 2
    return taus, w / w.sum()


def _lag_weights(form, strength, unit_err_K, unit_max_K, unit_K):
    """Mode weights: strength 1 puts the film C_LAG * unit_K (rms over the readings) off its
    steady state, and never more than LAG_MAX * unit_K anywhere on its path; ``unit_err_K`` and
    ``unit_max_K`` are those errors for unit total weight (linear in the weights)."""
    taus, w = _lag_modes(form)
    if form["sign"] == "mixed":
        taus = np.concatenate([taus, [form["tcr_tau_s"]]])
        w = np.concatenate([w, [-form["tcr_ratio"]]])
    a1 = min(C_LAG * unit_K / max(unit_err_K, 1e-9), LAG_MAX * unit_K / max(unit_max_K, 1e-9))
    if form["sign"] == "overshoot":
        return taus, -w * 0.5 * (1.0 - np.exp(-strength * a1 / 0.5))
    return taus, w * 0.8 * (1.0 - np.exp(-strength * a1 / 0.8))


def _lag_shape(form):
    taus, w = _lag_modes(form)
    if form["sign"] == "mixed":
        return np.concatenate([taus, [form["tcr_tau_s"]]]), np.concatenate([w, [-form["tcr_ratio"]]])
    return taus, (-w if form["sign"] == "overshoot" else w)


# --------------------------------------------------------------------------- shapes

def _reversible_shape(form, z, v_tr, v_max):
    c = v_tr + 0.5 * form["centre_rel"]
    w = form["width_V"]
    shape = form["shape"]

    def f(zz):
        s = (zz - c) / w
        if shape == "sigmoid":
            return np.tanh(s)
        if shape == "bump":
            return np.exp(-0.5 * s * s)
        if shape == "skew_bump":
            ss = np.where(s > 0, s / form["skew"], s)
            return np.exp(-0.5 * ss * ss)
        if shape == "knee":
            return np.logaddexp(0.0, s)
        return s ** 3  # cubic
    grid = np.linspace(0.0, v_max, 241)
    fg = f(grid)
    if shape in ("knee", "cubic", "sigmoid"):
        lo = f(np.array([0.0]))[0]
        fg = fg - lo
        return (f(z) - lo) / max(np.max(np.abs(fg)), 1e-12)
    return f(z) / max(np.max(np.abs(fg)), 1e-12)


def _joule_q(form, z):
    if form["shape"] == "power":
        return z * z
    if form["shape"] == "alpha_T":
        g = form["gamma"]
        return (z ** 2 + g * z ** 4) / (1.0 + g)
    b = form["beta"]
    return (1.0 - np.exp(-b * z * z)) / (1.0 - np.exp(-b))


def _nonlin(shape, direction, xi):
    if shape == "tanh":
        return np.tanh(xi)
    if shape == "sinh":
        return np.sinh(np.clip(xi, -50, 50))
    if shape == "exp":
        return direction * np.expm1(np.clip(direction * xi, -50, 50))
    if shape == "erf":
        return 0.5 * np.sqrt(np.pi) * special.erf(xi)
    return xi / np.sqrt(1.0 + xi * xi)


def _nonlin_width(form, scales):
    """The width W (um) at which the PSD departs from linear by C_NONLIN of the swing."""
    half = 0.5 * (scales.u_hi - scales.u_lo)
    pc = 0.5 * (scales.u_hi + scales.u_lo) + form["centre_offset"] * half
    p = np.linspace(scales.u_lo, scales.u_hi, 201)
    target = C_NONLIN * scales.swing

    def dev(W):
        return float(np.max(np.abs(pc + W * _nonlin(form["shape"], form["direction"], (p - pc) / W) - p)))
    lo, hi = np.log(1e-2 * half), np.log(1e4 * half)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if dev(np.exp(mid)) > target:
            lo = mid
        else:
            hi = mid
    return float(np.exp(hi)), pc


def _creep_kernel(form, t):
    t = np.maximum(t, 1e-6)
    k = form["kernel"]
    if k == "exp_modes":
        return sum(w * np.exp(-t / tau) for w, tau in zip(form["weights"], form["taus_s"]))
    if k == "log_uniform":
        lo, hi = form["tau_lo_s"], form["tau_hi_s"]
        return (special.exp1(t / hi) - special.exp1(t / lo)) / np.log(hi / lo)
    if k == "power":
        return (1.0 + t / form["tau0_s"]) ** (-form["alpha"])
    return np.exp(-(t / form["tau_s"]) ** form["beta"])


def _creep_drive(form, src, scales, device):
    """The size of every change (um), through the size law and the direction asymmetry."""
    src0 = device.output(-device.phase_swing_um, 0.0) if form["source"] == "total" else -scales.amp
    d = np.diff(np.concatenate([[src0], src]))
    ref = 0.3 * scales.swing  # a typical change: the size laws are 1 there
    if form["size_law"] == "saturating":
        sat = form["size_scale_frac"] / 0.3
        ad = np.maximum(np.abs(d) / ref, 1e-12) / sat
        size = np.tanh(ad) / ad / (np.tanh(1.0 / sat) * sat)
    elif form["size_law"] == "power":
        size = np.where(np.abs(d) > 1e-12 * ref,
                        np.maximum(np.abs(d) / ref, 1e-12) ** (form["size_power"] - 1.0), 0.0)
    else:
        size = np.ones_like(d)
    return d * size * (1.0 + form["asym"] * np.sign(d))


def _clean_source(device, tl, source):
    """The clean device's deflection (or phase part) at every segment of the session."""
    h = device.hysteresis()
    out = np.empty(tl.v.size)
    for j, v in enumerate(tl.v):
        p = h.move(float(v))
        out[j] = device.output(p, float(v)) if source == "total" else p
        if tl.rest[j]:
            h = device.hysteresis()
            out[j] = device.output(h.value(), 0.0) if source == "total" else h.value()
    return out


# --------------------------------------------------------------------------- simulate

def simulate(device, schedules, effects, seed, noise_um):
    for fam, _, s in effects:
        if fam not in ALL:
            raise KeyError(f"unknown mechanism {fam!r}")
        if not np.isfinite(s) or s < 0:
            raise ValueError(f"strength of {fam} must be >= 0")
    on = {fam: (form, float(s)) for fam, form, s in effects if s > 0}
    tl = timeline(schedules, seed)
    nseg = tl.v.size
    scales = device_scales(device) if on else None
    k2 = device.kelvin_per_V2
    v_min, v_max = device.v_min_V, device.v_max_V
    runs = tl.run_bounds
    t_end = max(float(tl.B[-1]) if nseg else 0.0, 1.0)
    grid = paths.session_grid(t_end)

    def path(fam):
        form = on[fam][0]
        return paths.session_path(form["path"], stream(seed, fam, "path"), grid, runs)

    # ---- heater drive and thermal paths
    thermal = any(f in on for f in _THERMAL)
    x_samples = vth = None
    amb_at = None
    if thermal:
        pf_mid = np.ones(nseg)
        pf_fun = None
        if "heater_anneal" in on:
            form, s = on["heater_anneal"]
            rise_tr = max(device.transition_heating_C - device.ambient_C, 10.0)
            delta = s * C_ANNEAL * scales.unit_K / rise_tr
            if form["dose"] == "energy":
                rate = (tl.v / v_max) ** 2
            elif form["dose"] == "arrhenius":
                rate = np.exp((device.rise_K(tl.v) - device.rise_K(v_max)) / form["arrhenius_K"])
            else:
                rate = (tl.v / v_max) ** form["current_power"]
            dose0 = np.concatenate([[0.0], np.cumsum(rate * (tl.B - tl.A) / 3600.0)[:-1]])
            d0h, pw, kin = form["d0_h"], form["power"], form["kinetics"]

            def hk(d):
                z = np.maximum(d, 0.0) / d0h
                return {"saturating": -np.expm1(-z), "log": np.log1p(z), "power": z ** pw}[kin]
            prior = form["prior_h"] * d0h
            href = hk(prior + 1.0) - hk(prior)

            def pf_fun(j, dt):  # power factor of segment(s) j, dt seconds after their start
                dose = dose0[j] + rate[j] * dt / 3600.0
                return np.maximum(1.0 + form["sign"] * delta * (hk(prior + dose) - hk(prior)) / href, 0.3)
            pf_mid = pf_fun(np.arange(nseg), 0.5 * (tl.B - tl.A))
        lag = "thermal_lag" in on
        if lag:
            offs = np.concatenate([np.zeros((nseg, 1)),
                                   0.05 * (np.maximum(tl.e - tl.A, 0.06)[:, None] / 0.05)
                                   ** (np.arange(10)[None, :] / 9.0)], axis=1)
        else:
            offs = np.stack([np.zeros(nseg), tl.e - tl.A], axis=1)
        jj = np.repeat(np.arange(nseg)[:, None], offs.shape[1], axis=1)
        r_mid = device.rise_K(tl.v) * pf_mid
        r_now = device.rise_K(tl.v)[:, None] * (pf_fun(jj, offs) if pf_fun else np.ones_like(offs))
        r_eval = device.rise_K(tl.v) * (pf_fun(np.arange(nseg), tl.e - tl.A) if pf_fun else 1.0)
        film_rise = r_now.copy()
        heat_eval = r_eval.copy()
        if lag:
            form, s = on["thermal_lag"]
            taus, w_shape = _lag_shape(form)
            gam = form["tau_temp_coeff"]
            tau_seg = taus[None, :] / (1.0 + gam * r_mid[:, None] / 50.0)
            y = np.zeros((nseg, taus.size))
            state = np.zeros(taus.size)
            dur = tl.B - tl.A
            decay = np.exp(-dur[:, None] / tau_seg)
            for j in range(nseg):
                y[j] = state
                state = r_mid[j] + (state - r_mid[j]) * decay[j]
            at_eval = (y - r_mid[:, None]) * np.exp(-(tl.e - tl.A)[:, None] / tau_seg)
            reading = ~tl.rest
            relax = np.exp(-offs[:, None, :] / tau_seg[:, :, None])
            err = at_eval[reading] @ w_shape if reading.any() else np.ones(1)
            on_path = np.einsum("jm,jmo->jo", (y - r_mid[:, None]) * w_shape[None, :], relax)
            unit_err, unit_max = float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(on_path[reading])))
            _, a = _lag_weights(form, s, unit_err, unit_max, scales.unit_K)
            dev0 = (y - r_mid[:, None]) * a[None, :]
            film_rise += np.einsum("jm,jmo->jo", dev0, relax)
            heat_eval += np.sum(dev0 * np.exp(-(tl.e - tl.A)[:, None] / tau_seg), axis=1)
        if "ambient_drift" in on:
            form, s = on["ambient_drift"]
            room = paths.session_path(form["path"], stream(seed, "ambient_drift", "path"), grid, runs)
            pkg = paths.normalise(grid, paths.lowpass(room, form["package_tau_s"]), runs)
            amp_K = s * C_AMBIENT * scales.unit_K
            amb_at = (lambda t: amp_K * np.interp(t, grid, pkg))
            film_rise += amb_at(tl.A[:, None] + offs)
        x_samples = device.equivalent_voltage(film_rise)
        vth = device.equivalent_voltage(heat_eval) if (lag or pf_fun) else tl.v.copy()
    else:
        vth = tl.v.copy()

    # ---- the film
    inter = _interaction_feel(device, scales, *on["interaction"]) if "interaction" in on else None
    acc = _accommodation_spec(device, scales, *on["accommodation"]) if "accommodation" in on else None
    film = Film(device, scales, inter, acc)
    phase = np.empty(nseg)
    x_eval = np.empty(nseg)
    x_prev = v_min
    for j in range(nseg):
        if x_samples is None:
            pts = [float(tl.v[j])]
        else:
            pts = _turning_points(x_prev, x_samples[j])
        if tl.rest[j]:
            film.min_eff = np.inf
        for x in pts:
            ph = film.move(x)
        x_prev = pts[-1]
        x_eval[j] = x_prev
        if tl.rest[j] and film.min_eff <= v_min:
            film.reset()  # negative saturation wipes the memory: the next run starts fresh
            ph = film.value()
        phase[j] = ph

    # ---- the beam
    if "joule_power" in on:
        form, s = on["joule_power"]
        zg = np.linspace(0.0, 1.0, 201)
        maxdev = float(np.max(np.abs(_joule_q(form, zg) - zg)))
        eps = s * C_JOULE * scales.swing / (abs(device.thermal_um_per_V) * v_max * max(maxdev, 1e-6))
        vth = vth + eps * (v_max * _joule_q(form, np.clip(vth / v_max, 0.0, None)) - vth)
    u = np.array([device.output(p, vt) for p, vt in zip(phase, vth)])
    if "ambient_drift" in on and on["ambient_drift"][0]["expansion_coupling"] > 0:
        kappa = on["ambient_drift"][0]["expansion_coupling"]
        dvdT = 1.0 / (2.0 * k2 * max(scales.v_tr, 0.5))
        u = u + device.thermal_um_per_V * kappa * dvdT * amb_at(tl.e)
    if "reversible" in on:
        form, s = on["reversible"]
        z = tl.v if form["input"] == "voltage" else x_eval
        u = u + form["sign"] * s * C_REVERSIBLE * scales.swing * _reversible_shape(form, z, scales.v_tr, v_max)
    if "creep" in on:
        form, s = on["creep"]
        g = _creep_drive(form, u if form["source"] == "total" else phase, scales, device)
        dt = tl.e[:, None] - tl.A[None, :]
        kern = np.where(dt > 0, _creep_kernel(form, np.where(dt > 0, dt, 1.0)), 0.0)
        # strength 1: the creep still under way at the readings is C_CREEP of the swing (rms),
        # on the clean device's changes (the unit does not depend on the other mechanisms)
        g_ref = _creep_drive(form, _clean_source(device, tl, form["source"]), scales, device)
        unit = float(np.sqrt(np.mean((kern @ g_ref)[~tl.rest] ** 2))) if (~tl.rest).any() else 1.0
        c = s * C_CREEP * scales.swing / max(unit, 1e-9 * scales.swing)
        u = u - form["sign"] * c * (kern @ g)
    if "backlash" in on:
        form, s = on["backlash"]
        b = s * C_BACKLASH * scales.swing
        u0 = device.output(-device.phase_swing_um, 0.0)
        init = {"down": 1.0, "centre": 0.0, "up": -1.0}[form["initial"]]
        if form["kind"] == "distributed":
            n = form["n_plays"]
            r = b * np.arange(1, n + 1) / n * 2.0 * n / (n + 1)  # mean width b
            w = np.exp(-form["decay"] * np.arange(1, n + 1) / n)
            w = w / w.sum()
        else:
            r, w = np.array([b]), np.array([1.0])
        m = u0 + init * r
        out = np.empty(nseg)
        prev = u0
        for j in range(nseg):
            uj = u[j]
            if form["kind"] == "dahl":
                e = m[0] - prev
                sh = form["sharpness"] / b
                du = uj - prev
                if du > 0:
                    e = b * ((1.0 + e / b) * np.exp(-du * sh) - 1.0)
                elif du < 0:
                    e = b - (b - e) * np.exp(du * sh)
                m = np.array([uj + e])
            else:
                m = np.clip(m, uj - r, uj + r)
            out[j] = float(w @ m)
            prev = uj
        u = out

    # ---- the PSD
    y = u
    if "baseline_drift" in on:
        s = on["baseline_drift"][1]
        y = y + s * C_BASELINE * scales.swing * np.interp(tl.e, grid, path("baseline_drift"))
    if "sensor_nonlinearity" in on:
        form, s = on["sensor_nonlinearity"]
        W1, pc = _nonlin_width(form, scales)
        W = W1 / s
        y = pc + W * _nonlin(form["shape"], form["direction"], (y - pc) / W)
    if "gain_drift" in on:
        s = on["gain_drift"][1]
        umax = max(abs(scales.u_lo), abs(scales.u_hi))
        y = y * (1.0 + s * C_GAIN * scales.swing / umax * np.interp(tl.e, grid, path("gain_drift")))

    results = []
    for r, (sch, idx) in enumerate(zip(schedules, tl.run_index)):
        yr = np.array(y[idx], dtype=float)
        if "first_point" in on:
            form, s = on["first_point"]
            yr = yr + _first_point(form, s * C_FIRST * scales.swing, np.asarray(sch["v_V"], float),
                                   stream(seed, "first_point", str(r)), v_max)
        if noise_um is not None and noise_um > 0:
            yr = yr + noise_um * stream(seed, "noise", str(r)).standard_normal(yr.size)
        results.append({"t_s": tl.t_s[r], "v_V": np.asarray(sch["v_V"], dtype=float).copy(), "y_um": yr})
    return results


def _first_point(form, amp, v, rng, v_max):
    n = v.size
    jitter = 1.0 + form["jitter"] * rng.standard_normal(n)
    out = np.zeros(n)
    prev_dir, last = 0, 0.0
    for i in range(n):
        dv = v[i] - last
        last = v[i]
        d = int(np.sign(dv))
        if d == 0:
            continue
        reversal = prev_dir != 0 and d != prev_dir
        prev_dir = d
        if not reversal:
            continue
        mode = form["direction"]
        if mode == "same":
            a = form["sign"] * (1.0 + form["asym"] * d)
        elif mode == "signed":
            a = form["sign"] * d * (1.0 + form["asym"] * d)
        elif mode == "up_only":
            a = form["sign"] * (d > 0)
        else:
            a = form["sign"] * (d < 0)
        if form["size_law"] == "saturating":
            a *= -np.expm1(-abs(dv) / form["size_v0_V"])
        elif form["size_law"] == "power":
            a *= (abs(dv) / v_max) ** form["size_power"]
        rho = form["linger"]
        a *= amp * jitter[i] * (1.0 - 0.6 * rho)
        k = 0
        while i + k < n and (k == 0 or rho ** k > 1e-3):
            out[i + k] += a * rho ** k
            k += 1
            if rho == 0.0:
                break
    return out
