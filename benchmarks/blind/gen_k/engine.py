"""The session simulator: the base device plus the unmodelled mechanisms, in their physical order.

Signal chain of one reading (each stage only present when its mechanism has strength > 0):

    heater v --(Joule power, slow thermal paths, room temperature)--> film temperature
      --> hysterons' input x (equivalent volts) --(mean field of the stress)--> z
      --> Preisach phase (weights that change with use) --> deflection u of the beam
          (+ bimorph law, anhysteretic part, visco-elastic creep, adsorbed-layer stress)
      --> optical-lever mount (play) --> PSD (nonlinear response, sensitivity, zero)
      --> direction-change transient of the read-out --> logger (timing, noise).

With every strength 0 the chain reduces to exactly ``base.clean_outputs``: the hysterons are moved
to ``v`` and the output is ``device.output(phase, v)``.

Randomness: every realisation (drift paths, timing, noise, the gap between runs) comes from a
stream of its own, seeded by (seed, run index, purpose) -- never shared in sequence between runs or
mechanisms -- so a run does not depend on the runs after it, nor a drift on the strength or on the
other mechanisms present.  States that physically persist (heat in the package, creep, adsorbed
water, the mount's position in its play, the film's cycle count) are carried from one run to the
next through the ten-minute pause at 0 V, which only makes later runs depend on earlier ones.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import zlib

import numpy as np
from scipy.optimize import brentq
from scipy.special import erf

from benchmarks.blind import base

from .forms import LIBRARY, OUTSIDE

# ------------------------------------------------------------------------------------------------
# strength units: strength 1 is roughly a 1 % of the output swing effect (see README.md)

C_LAG = 0.012        # slow fraction scale of the thermal paths (divided by the lag left after 20 s)
C_CREEP = 0.02       # fully relaxed creep, fraction of the driving deflection's range
C_BASE = 0.01        # rms zero drift, fraction of the swing
C_AMB_K = 0.20       # rms room-temperature drift (K)
C_JOULE = 0.015      # peak bimorph-law departure, fraction of the swing
C_SENS = 0.012       # peak calibrated PSD non-linearity, fraction of the swing (small-strength slope)
C_REV = 0.012        # peak anhysteretic part, fraction of the swing
G_INT = 0.05         # mean-field loop gain at strength 1
G_MAX = 0.6          # the loop gain never exceeds this (no avalanches)
C_FP = 0.02          # direction-change transient, fraction of the swing
C_GAIN = 0.01        # rms relative sensitivity drift times max|u|, fraction of the swing
C_BL = 0.02          # play of the mount (loop width), fraction of the swing
C_ACC = 0.03         # weight-pattern change (in units of the phase swing) after ~10 cycles
C_ADS = 0.015        # deflection of a fully desorbed layer, fraction of the swing

# logger / read-out electronics
PLC_S = 0.020        # ADC integration window: one power-line cycle (50 Hz) per reading
READ_OVERHEAD_S = 0.002
GAP_S = 600.0        # pause at 0 V between runs (nominal)
DRIFT_DT_S = 5.0     # time step on which drift paths are synthesised

R_GAS = 8.314462618e-3  # kJ / (mol K)

_TAGS = {name: zlib.crc32(name.encode()) for name in
         LIBRARY + OUTSIDE + ("timing", "noise", "gap")}


def _stream(seed: int, run: int, tag: str) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(
        [0x67656E6B, int(seed) % (1 << 63), int(run), _TAGS[tag]]))


# ------------------------------------------------------------------------------------------------
# device context: quantities derived once per simulate() from the public API of base


@functools.lru_cache(maxsize=8)
def _layout(levels: int, v_min: float, v_max: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(up-switching bin, down-switching bin) of every Preisach cell, probed through the public API.

    A device whose cell weights are their index + 1 is driven along first-order reversal curves
    from negative saturation to every grid edge; the mixed second difference of the (up-switched)
    weight sum isolates the cell of each (alpha, beta) bin pair.  None if the probe is not clean.
    """
    n = levels * (levels + 1) // 2
    w = np.arange(1, n + 1, dtype=float)
    probe = base.BaseDevice(levels=levels, v_min_V=v_min, v_max_V=v_max, density_um=w, bias_um=0.0,
                            thermal_um_per_V=0.0, kelvin_per_V2=1.0, ambient_C=25.0,
                            transition_heating_C=60.0, transition_cooling_C=50.0,
                            transition_width_C=1.0)
    edges = np.linspace(v_min, v_max, levels + 1)
    tot = w.sum()
    U = np.zeros((levels + 1, levels + 1))
    for a in range(1, levels + 1):
        h = probe.hysteresis()
        U[a, a] = (h.move(edges[a]) + tot) / 2
        for b in range(a - 1, -1, -1):
            U[a, b] = (h.move(edges[b]) + tot) / 2
        U[a, a + 1:] = U[a, a]
    ai = np.full(n, -1)
    bj = np.full(n, -1)
    for i in range(levels):
        for j in range(i + 1):
            c = U[i + 1, j + 1] - U[i, j + 1] - U[i + 1, j] + U[i, j]
            k = int(round(c)) - 1
            if abs(c - round(c)) > 1e-6 or not 0 <= k < n or ai[k] >= 0:
                return None
            ai[k], bj[k] = i, j
    if np.any(ai < 0):
        return None
    return ai, bj


class _Ctx:
    def __init__(self, device: base.BaseDevice) -> None:
        self.dev = device
        self.vmin, self.vmax = float(device.v_min_V), float(device.v_max_V)
        up = np.linspace(self.vmin, self.vmax, 61)
        self.v_loop = np.concatenate([up, up[::-1][1:]])
        h = device.hysteresis()
        self.phi_loop = np.array([h.move(v) for v in self.v_loop])
        self.u_loop = device.bias_um + device.thermal_um_per_V * self.v_loop + self.phi_loop
        self.u_lo, self.u_hi = float(self.u_loop.min()), float(self.u_loop.max())
        self.swing = self.u_hi - self.u_lo
        self.S = float(device.phase_swing_um)
        self.r_max = float(device.rise_K(self.vmax))
        self.layout = _layout(int(device.levels), self.vmin, self.vmax)
        d = np.asarray(device.density_um, dtype=float)
        if self.layout is not None:
            ai, bj = self.layout
            step = (self.vmax - self.vmin) / device.levels
            asc = 2 * np.bincount(ai, weights=d, minlength=device.levels) / step
            desc = 2 * np.bincount(bj, weights=d, minlength=device.levels) / step
            self.max_slope = float(max(asc.max(), desc.max()))
        else:
            self.max_slope = float(np.max(np.abs(np.diff(self.phi_loop) / np.diff(self.v_loop)
                                                 [np.abs(np.diff(self.v_loop)) > 0])) * 1.5)
        self.max_slope = max(self.max_slope, 1e-9)

    def eq_volts(self, rise):
        return self.dev.equivalent_voltage(rise)


# ------------------------------------------------------------------------------------------------
# drift paths (unit rms over the run, zero at the run's start)


def _unit(p: np.ndarray) -> np.ndarray:
    """Zero at the start and unit rms: only for Gaussian paths, whose realised rms is a stable scale."""
    p = p - p[0]
    r = float(np.sqrt(np.mean(p ** 2)))
    return p / r if r > 0 else p


def _wave(kind: str, phase: np.ndarray) -> np.ndarray:
    if kind == "triangle":
        return 2 / np.pi * np.arcsin(np.sin(phase))
    if kind == "sawtooth":  # slow heating, quick drop: a bang-bang thermostat with a fast cooler
        return 2 * ((phase / (2 * np.pi)) % 1.0) - 1
    return np.sin(phase)


def _drift_path(form: dict, rng: np.random.Generator, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    n = int(math.ceil(t_end / DRIFT_DT_S)) + 2
    t = np.arange(n) * DRIFT_DT_S
    total = np.zeros(n)
    for name in sorted(form["components"]):
        weight = form["components"][name]
        if name == "powerlaw":
            m = 1 << int(math.ceil(math.log2(2 * n)))
            f = np.fft.rfftfreq(m, DRIFT_DT_S)
            amp = np.zeros_like(f)
            amp[1:] = f[1:] ** (-form["alpha"] / 2) / np.sqrt(1 + (2 * np.pi * f[1:] * form["corner_s"]) ** 2)
            spec = np.fft.rfft(rng.normal(size=m)) * amp
            p = _unit(np.fft.irfft(spec, m)[:n])
        elif name == "warmup":
            tau = form["warmup_tau_s"] * rng.uniform(0.7, 1.4)
            p = form["warmup_sign"] * rng.uniform(0.7, 1.8) * (1 - np.exp(-t / tau))
        elif name == "hvac":
            period = form["hvac_period_s"] * rng.uniform(0.9, 1.1)
            p = 1.4 * _wave(form["hvac_wave"], 2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        elif name in ("slips", "mode_hops", "door"):
            # events: a Poisson count (at least one), sizes of unit scale divided by the square root
            # of the expected count, so that the path has about unit rms whatever the rate
            rate = {"slips": form.get("slips_rate_per_h"), "mode_hops": form.get("hops_rate_per_h"),
                    "door": form.get("door_rate_per_h")}[name] / 3600.0
            expected = max(rate * t_end, 1.0)
            k = max(1, int(rng.poisson(rate * t_end)))
            times = rng.uniform(0, t_end, size=k)
            if name == "door":
                sizes = rng.choice([-1.0, 1.0], size=k) * rng.uniform(0.5, 1.5, size=k) * 1.5
            else:
                sizes = np.clip(rng.laplace(scale=1 / math.sqrt(2), size=k), -3, 3) * 1.5
            sizes = sizes / math.sqrt(expected)
            p = np.zeros(n)
            for ti, si in zip(times, sizes):
                dt = np.maximum(t - ti, 0.0)
                on = t > ti
                if name == "slips":
                    p += si * on * (1 - np.exp(-dt / form["slip_settle_s"]))
                elif name == "mode_hops":
                    p += si * on
                else:  # a door opened: a quick excursion of the room air, then the HVAC recovers it
                    p += si * on * (np.exp(-dt / form["door_recovery_s"]) - np.exp(-dt / 60.0))
        elif name == "trend":
            p = rng.normal() * math.sqrt(3.0) * t / max(t_end, 1.0)
        else:
            raise ValueError(f"unknown drift component {name!r}")
        total += weight * (p - p[0])
    weights = np.array(list(form["components"].values()))
    total = total / math.sqrt(float(np.sum(weights ** 2)))
    return t, np.clip(total, -4.0, 4.0)


# ------------------------------------------------------------------------------------------------
# timing of the logger


def _timing(seed: int, run: int, dwell: np.ndarray, K: int) -> tuple[np.ndarray, np.ndarray]:
    """(set-point change times, reading times) of one run, from the run's own stream."""
    rng = _stream(seed, run, "timing")
    n = dwell.size
    latency = 0.02 + rng.gamma(2.0, 0.015, size=n)           # DAC command over the bus
    hiccup = rng.uniform(size=n) < 0.005                        # the logging PC stalls now and then
    latency = latency + hiccup * rng.uniform(0.3, 2.0, size=n)
    trigger = rng.uniform(0.0, 0.01, size=n)                    # read trigger jitter
    burst = K * (PLC_S + READ_OVERHEAD_S)
    t_change = np.empty(n)
    t_read = np.empty(n)
    t = 0.0
    for i in range(n):
        t += latency[i]
        t_change[i] = t
        t_read[i] = t + dwell[i] + trigger[i] + burst / 2
        t = t_read[i] + burst / 2
    return t_change, t_read


# ------------------------------------------------------------------------------------------------
# static laws


def _joule_law(form: dict):
    xi = np.linspace(0.0, 1.0, 401)

    def h(x):
        x = np.clip(x, 0.0, None)
        if form["law"] == "power_exponent":
            return x ** form["exponent"]
        b, g = form["tcr_compression"], form["alpha_tc"]
        r = (1 + b) * x ** 2 / (1 + b * x ** 2)
        return (r + g * r ** 2 / 2) / (1 + g / 2)

    norm = float(np.max(np.abs(h(xi) - xi)))
    return lambda x: (h(x) - x) / norm


def _reversible_law(form: dict, ctx: _Ctx):
    dev = ctx.dev
    th, tc = dev.transition_heating_C, dev.transition_cooling_C
    t_c = (th + tc) / 2 + form["centre_rel"] * (th - tc) - dev.ambient_C
    vc = float(ctx.eq_volts(t_c))
    w = form["width_V"]
    shape = form["shape"]

    def f(x):
        x = np.asarray(x, dtype=float)
        if shape == "sigmoid":
            return np.tanh((x - vc) / w)
        if shape == "skew_sigmoid":
            return (1 + np.exp(-(x - vc) / w)) ** (-form["skew"])
        if shape == "bump":
            return np.exp(-0.5 * ((x - vc) / w) ** 2)
        if shape == "power":
            return np.clip(x / ctx.vmax, 0, None) ** form["exponent"]
        z = 2 * x / ctx.vmax - 1
        return np.polynomial.legendre.legval(z, np.concatenate([[0.0], form["coeffs"]]))

    grid = np.linspace(ctx.vmin, ctx.vmax, 601)
    f0 = float(f(0.0))
    norm = float(np.max(np.abs(f(grid) - f0)))
    norm = norm if norm > 0 else 1.0
    return lambda x: form["sign"] * (f(x) - f0) / norm


def _sensor_law(form: dict, ctx: _Ctx, strength: float):
    lo, hi = ctx.u_lo, ctx.u_hi
    uc = (lo + hi) / 2 + form["centre_offset"] * (hi - lo) / 2
    L = form["range_ratio"] * max(abs(lo - uc), abs(hi - uc))
    law = form["law"]

    def G(d):
        if law == "tanh":
            return L * np.tanh(d / L)
        if law == "arctan":
            return L * np.arctan(d / L)
        if law == "erf":
            return L * erf(d / L) * np.sqrt(np.pi) / 2
        if law == "cubic":
            return d - d ** 3 / (3 * L ** 2)
        if law == "barrel":
            return d + d ** 3 / (3 * L ** 2)
        return d + form["orientation"] * d ** 2 / (2 * L)

    p1 = lo + form["cal_points"][0] * (hi - lo)
    p2 = lo + form["cal_points"][1] * (hi - lo)
    g1, g2 = G(p1 - uc), G(p2 - uc)

    def calibrated(u):
        return p1 + (G(u - uc) - g1) * (p2 - p1) / (g2 - g1)

    grid = np.linspace(lo, hi, 401)
    dev = float(np.max(np.abs(calibrated(grid) - grid)))
    lam = 1 - math.exp(-strength * C_SENS * ctx.swing / max(dev, 1e-12))
    return lambda u: u + lam * (calibrated(u) - u)


def _accommodation_mask(form: dict, ctx: _Ctx) -> np.ndarray:
    d = np.asarray(ctx.dev.density_um, dtype=float)
    if ctx.layout is None:
        s = sum(form["pattern"].values())
        return np.full(d.size, 1.0 if s >= 0 else -1.0)
    ai, bj = ctx.layout
    step = (ctx.vmax - ctx.vmin) / ctx.dev.levels
    alpha = ctx.vmin + (ai + 0.5) * step
    beta = ctx.vmin + (bj + 0.5) * step
    wt = np.abs(d) / max(np.sum(np.abs(d)), 1e-300)

    def standard(q):
        mu = np.sum(wt * q)
        sd = math.sqrt(max(np.sum(wt * (q - mu) ** 2), 1e-300))
        return (q - mu) / sd

    zm, zw = standard((alpha + beta) / 2), standard(alpha - beta)
    masks = {"amplitude": np.ones(d.size), "shift": zm, "width": zw, "spread": standard(zm ** 2)}
    M = np.zeros(d.size)
    for k, a in form["pattern"].items():
        M += a * masks[k]
    return M


# ------------------------------------------------------------------------------------------------
# the simulator


def _parse(effects) -> dict:
    active = {}
    for family, form, strength in effects:
        if family not in LIBRARY + OUTSIDE:
            raise ValueError(f"unknown mechanism family {family!r}")
        strength = float(strength)
        if strength < 0 or not math.isfinite(strength):
            raise ValueError(f"strength must be finite and >= 0, got {strength}")
        if strength > 0:
            if family in active:
                raise ValueError(f"mechanism {family!r} given twice")
            active[family] = (form, strength)
    return active


def _relax(z, target, rate, dt):
    return target + (z - target) * np.exp(-rate * dt)


class _Session:
    """Mechanism states that persist across runs, and the per-device laws."""

    def __init__(self, device, active, seed):
        self.dev, self.act, self.seed = device, active, seed
        self.ctx = _Ctx(device) if active else None
        ctx = self.ctx
        # thermal lag
        if "thermal_lag" in active:
            f, s = active["thermal_lag"]
            taus = np.asarray(f["taus_s"], float)
            shares = np.asarray(f["shares"], float)
            rho = max(float(np.sum(shares * np.exp(-8.0 / taus))), 0.03)  # lag left after the shortest dwell
            lam = 1 - math.exp(-s * C_LAG / rho)
            self.lag_taus, self.lag_a, self.lag_gamma = taus, lam * shares, float(f["conductance_tc"])
            self.lag_q = np.zeros(taus.size)
        # interaction
        if "interaction" in active:
            f, s = active["interaction"]
            g = G_MAX * math.tanh(s * G_INT / G_MAX)
            self.int_kappa = g / ctx.max_slope
            self.int_sign = float(f["sign"])
            self.int_ref = float(f["ref_frac"]) * ctx.S
            self.int_sat = float(f["sat_scale"]) * ctx.S if f["law"] == "saturating" else None
        # accommodation
        if "accommodation" in active:
            f, s = active["accommodation"]
            d0 = np.asarray(device.density_um, float)
            M = _accommodation_mask(f, ctx)
            # the cells that carry weight set the bound (the empty tails of the plane do not matter)
            cap = max(float(np.max(np.abs(M[np.abs(d0) >= 0.01 * np.max(np.abs(d0))]))), 1e-12)
            M = np.clip(M, -cap, cap)
            # scale the pattern so that its phase part peaks at the phase swing S on the major loop
            probe = dataclasses.replace(device, density_um=d0 * M).hysteresis()
            peak = max(max(abs(probe.move(x)) for x in ctx.v_loop), 1e-12)
            M = M * ctx.S / peak
            self.acc_dev = dataclasses.replace(device, density_um=d0 * M)
            self.acc_emax = 0.5 / (cap * ctx.S / peak)
            self.acc_N = 0.0
        # creep
        if "creep" in active:
            f, s = active["creep"]
            self.cr_taus = np.asarray(f["taus_s"], float)
            self.cr_w = np.asarray(f["weights"], float)
            e_loop = ctx.phi_loop + f["thermal_mix"] * device.thermal_um_per_V * ctx.v_loop
            self.cr_ref = float(e_loop[0])
            self.cr_range = max(float(np.ptp(e_loop)), 1e-9)
            self.cr_z = np.zeros(self.cr_taus.size)
        # adsorption
        if "surface_adsorption" in active:
            f, s = active["surface_adsorption"]
            self.ads_Ta = device.ambient_C + 273.15
            self.ads_theta = float(f["theta_ambient"])
            t_hot = self.ads_Ta + ctx.r_max
            self.ads_norm = max(self.ads_theta - self._theta_eq(t_hot), 1e-6)
        # backlash
        if "backlash" in active:
            f, s = active["backlash"]
            W = s * C_BL * ctx.swing * np.asarray(f["width_fracs"], float)
            a = float(f["asym"])
            self.bl_up, self.bl_dn = W * a / (1 + a), W / (1 + a)
            self.bl_w = np.asarray(f["weights"], float)
            self.bl_soft = f["kind"] == "soft"
            self.bl_take_up = f["takeup_frac"] * self.bl_up
            self.bl_take_dn = f["takeup_frac"] * self.bl_dn
            side = int(f["initial_side"])
            self.bl_g = {1: -self.bl_dn, -1: self.bl_up, 0: (self.bl_up - self.bl_dn) / 2}[side]
            self.bl_u = None
        # static laws
        if "joule_power" in active:
            self.joule = _joule_law(active["joule_power"][0])
        if "reversible" in active:
            self.rev = _reversible_law(active["reversible"][0], ctx)
        if "sensor_nonlinearity" in active:
            f, s = active["sensor_nonlinearity"]
            self.sens = _sensor_law(f, ctx, s)

    # -- adsorption laws
    def _theta_eq(self, T):
        f = self.act["surface_adsorption"][0]
        th_a = float(f["theta_ambient"])
        kp = th_a / (1 - th_a) * np.exp(f["heat_kJ_mol"] / R_GAS * (1 / T - 1 / self.ads_Ta))
        return kp / (1 + kp)

    def _ads_rate(self, T):
        f = self.act["surface_adsorption"][0]
        return np.exp(f["activation_kJ_mol"] / R_GAS * (1 / self.ads_Ta - 1 / T)) / f["tau_ambient_s"]

    def _ads_step(self, T, dt):
        self.ads_theta = float(_relax(self.ads_theta, self._theta_eq(T), self._ads_rate(T), dt))

    # -- thermal lag
    def _lag_tau(self, R):
        if self.lag_gamma == 0:
            return self.lag_taus
        mid = (R + self.lag_q) / 2
        return self.lag_taus / (1 + self.lag_gamma * np.clip(mid / self.ctx.r_max, 0, None))

    def _lag_relax(self, R, dt):
        self.lag_q = _relax(self.lag_q, R, 1 / self._lag_tau(R), dt)

    # -- creep
    def _creep_target(self, e):
        f, s = self.act["creep"]
        xi = (e - self.cr_ref) / self.cr_range
        return s * C_CREEP * self.cr_range * math.copysign(abs(xi) ** f["size_exponent"], xi)

    def _creep_step(self, Z, dt):
        f = self.act["creep"][0]
        rate = np.where(Z > self.cr_z, f["rate_up"], f["rate_down"]) / self.cr_taus
        self.cr_z = _relax(self.cr_z, Z, rate, dt)

    # -- backlash (rate independent: only the sequence of mount inputs matters)
    def _backlash(self, u):
        if self.bl_u is None:
            self.bl_u = u
        du = u - self.bl_u
        g = self.bl_g + du   # gap grows with the beam while the mount stays
        if self.bl_soft:
            g = np.asarray(self.bl_g, dtype=float)
            if du > 0:
                lim = self.bl_up - self.bl_take_up
                lin = np.maximum(lim - g, 0.0)
                rest = np.maximum(du - lin, 0.0)
                g = np.where(du <= lin, g + du,
                             self.bl_up - (self.bl_up - np.maximum(g, lim)) * np.exp(-rest / self.bl_take_up))
            elif du < 0:
                lim = -self.bl_dn + self.bl_take_dn
                lin = np.maximum(g - lim, 0.0)
                rest = np.maximum(-du - lin, 0.0)
                g = np.where(-du <= lin, g + du,
                             -self.bl_dn + (np.minimum(g, lim) + self.bl_dn) * np.exp(-rest / self.bl_take_dn))
        else:
            g = np.clip(g, -self.bl_dn, self.bl_up)
        self.bl_g, self.bl_u = g, u
        return u - float(np.sum(self.bl_w * g))

    # -- film
    def _field(self, phi):
        d = phi - self.int_ref
        if self.int_sat is not None:
            d = self.int_sat * math.tanh(d / self.int_sat)
        return self.int_sign * d

    def _solve_z(self, x, h, hM, eps):
        k = self.int_kappa

        def resid(z):
            phi = h.peek(z) + (eps * hM.peek(z) if hM is not None else 0.0)
            return z - x - k * self._field(phi)

        span = k * 2.2 * self.ctx.S * (1 + (0.5 if hM is not None else 0.0)) + 1e-9
        return brentq(resid, x - span, x + span, xtol=1e-11, rtol=1e-13, maxiter=200)

    def _acc_eps(self):
        f, s = self.act["accommodation"]
        N, N0 = self.acc_N, f["cycles_scale"]
        if f["law"] == "saturating":
            F = 1 - math.exp(-N / N0)
        elif f["law"] == "log":
            F = math.log1p(N / N0) / math.log1p(10.0 / N0)
        else:
            F = (N / 10.0) ** f["exponent"]
        return self.acc_emax * math.tanh(s * C_ACC * F / self.acc_emax)

    # ------------------------------------------------------------------------------------------
    def run(self, r: int, schedule: dict, noise_um):
        dev, act, ctx = self.dev, self.act, self.ctx
        v = np.asarray(schedule["v_V"], dtype=float)
        dwell = np.asarray(schedule["dwell_s"], dtype=float)
        K = int(schedule.get("readings", 1))
        n = v.size
        t_change, t_read = _timing(self.seed, r, dwell, K)
        y = np.empty(n)

        if not act:  # the clean device, computed exactly as base.clean_outputs does
            h = dev.hysteresis()
            for i in range(n):
                y[i] = dev.output(h.move(v[i]), v[i])
        else:
            self._run_effects(r, v, t_change, t_read, y)

        if noise_um is not None:
            y = y + _stream(self.seed, r, "noise").normal(size=n) * float(noise_um)
        return {"t_s": t_read, "v_V": v.copy(), "y_um": y, "dwell_s": t_read - t_change}

    def _gap(self, r):
        """The pause at 0 V before run r (r >= 1): slow states relax."""
        G = GAP_S + _stream(self.seed, r, "gap").uniform(-30.0, 120.0)
        if "thermal_lag" in self.act:
            self._lag_relax(0.0, G)
        if "surface_adsorption" in self.act:
            self._ads_step(self.ads_Ta, G)
        return G

    def _run_effects(self, r, v, t_change, t_read, y):
        dev, act, ctx = self.dev, self.act, self.ctx
        n = v.size
        gap = self._gap(r) if r > 0 else 0.0
        t_end = float(t_read[-1]) + 1.0
        drift = {}
        for fam in ("ambient_drift", "baseline_drift", "gain_drift"):
            if fam in act:
                tg, p = _drift_path(act[fam][0], _stream(self.seed, r, fam), t_end)
                drift[fam] = np.interp(t_read, tg, p)
        amb = drift["ambient_drift"] * act["ambient_drift"][1] * C_AMB_K if "ambient_drift" in act else np.zeros(n)
        lag = "thermal_lag" in act
        temp_layer = lag or "ambient_drift" in act
        inter = "interaction" in act
        acc = "accommodation" in act

        h = dev.hysteresis()
        hM = self.acc_dev.hysteresis() if acc else None
        eps = self._acc_eps() if acc else 0.0
        phi0_prev = h.value()
        phi = phi0_prev + (eps * hM.value() if acc else 0.0)

        # states at the run's start (heater at 0 V)
        R_old, T_old = 0.0, dev.ambient_C + 273.15
        e_start = phi
        if "creep" in act:
            Z_old = self._creep_target(e_start)
            self._creep_step(Z_old, gap)  # the pause at 0 V (the session starts at rest: z = 0)
        if "backlash" in act:
            self._backlash(dev.output(phi, 0.0))
        t_state = 0.0
        x_last = float(ctx.eq_volts(float(np.sum(self.lag_a * self.lag_q)) + amb[0])) if lag else 0.0
        last_dir, fp_left, fp_amp, u_prev = -1, 0, 0.0, dev.output(phi, 0.0)
        fp_form = act["first_point"][0] if "first_point" in act else None
        v_prev = 0.0

        for i in range(n):
            R = float(dev.rise_K(v[i]))
            seg0 = t_change[i] - t_state           # old input, before the set-point change
            seg1 = t_read[i] - t_change[i]         # new input, up to the reading
            # ---- temperature layer
            if lag:
                self._lag_relax(R_old, seg0)
                film_pre = R_old - float(np.sum(self.lag_a * (R_old - self.lag_q)))
                taus = self._lag_tau(R)
                ts = np.concatenate([[0.0], np.geomspace(0.1, max(seg1, 0.2), 10)])
                rise = R - np.sum(self.lag_a[:, None] * (R - self.lag_q[:, None])
                                  * np.exp(-ts[None, :] / taus[:, None]), axis=0)
                self._lag_relax(R, seg1)
                rise_read = R - float(np.sum(self.lag_a * (R - self.lag_q)))
                rise[-1] = rise_read
                xs_all = ctx.eq_volts(np.concatenate([[film_pre], rise]) + amb[i])
                xs = _turning_points(x_last, np.asarray(xs_all, dtype=float))
                # the bimorph term is linear in the temperature deviation: the lag's missing (or
                # excess) rise counts at the mean K/V of the range
                v_th = v[i] + (rise_read - R) * ctx.vmax / ctx.r_max
                x_read = float(xs[-1])
            elif temp_layer:
                rise_read = R
                x_read = float(ctx.eq_volts(R + amb[i]))
                xs = [x_read]
                v_th = v[i]
            else:
                rise_read = R
                x_read = v[i]
                xs = [v[i]]
                v_th = v[i]
            # ---- film layer
            for x in xs:
                z = self._solve_z(x, h, hM, eps) if inter else x
                phi0 = h.move(z)
                if acc:
                    phiM = hM.move(z)
                    self.acc_N += abs(phi0 - phi0_prev) / (4 * ctx.S)
                    eps = self._acc_eps()
                    phi = phi0 + eps * phiM
                else:
                    phi = phi0
                phi0_prev = phi0
            x_last = float(xs[-1])
            # ---- deflection of the beam
            u = dev.output(phi, v_th)
            if "joule_power" in act:
                u += act["joule_power"][1] * C_JOULE * ctx.swing * math.copysign(1.0, dev.thermal_um_per_V) \
                    * float(self.joule(v_th / ctx.vmax))
            if "reversible" in act:
                u += act["reversible"][1] * C_REV * ctx.swing * float(self.rev(x_read))
            if "creep" in act:
                f = act["creep"][0]
                e = phi + f["thermal_mix"] * dev.thermal_um_per_V * v_th
                Z = self._creep_target(e)
                self._creep_step(Z_old, seg0)
                self._creep_step(Z, seg1)
                Z_old = Z
                u += f["sign"] * float(np.sum(self.cr_w * self.cr_z))
            if "surface_adsorption" in act:
                f, s = act["surface_adsorption"]
                T_new = dev.ambient_C + 273.15 + rise_read + amb[i]
                self._ads_step(T_old, seg0)
                self._ads_step(T_new, seg1)
                T_old = T_new
                u += f["sign"] * s * C_ADS * ctx.swing * (self.ads_theta - float(f["theta_ambient"])) / self.ads_norm
            # ---- mount of the optical lever
            m = self._backlash(u) if "backlash" in act else u
            # ---- PSD
            yv = self.sens(m) if "sensor_nonlinearity" in act else m
            if "gain_drift" in act:
                g1 = C_GAIN * ctx.swing / max(abs(ctx.u_lo), abs(ctx.u_hi))
                yv = yv * (1 + act["gain_drift"][1] * g1 * drift["gain_drift"][i])
            if "baseline_drift" in act:
                yv = yv + act["baseline_drift"][1] * C_BASE * ctx.swing * drift["baseline_drift"][i]
            if fp_form is not None:
                dv = v[i] - v_prev
                direction = int(np.sign(dv))
                if direction != 0 and direction != last_dir:
                    size = _fp_size(fp_form, abs(dv), abs(u - u_prev), ctx)
                    amp = fp_form["amp_rise"] if direction > 0 else fp_form["amp_fall"]
                    fp_amp = act["first_point"][1] * C_FP * ctx.swing * amp * size
                    fp_left = int(fp_form["linger_points"]) if fp_form["linger_ratio"] > 0 else 0
                    yv += fp_amp
                    last_dir = direction
                else:
                    if direction != 0:
                        last_dir = direction
                    if fp_left > 0:
                        fp_amp *= fp_form["linger_ratio"]
                        yv += fp_amp
                        fp_left -= 1
            y[i] = yv
            u_prev, v_prev, R_old, t_state = u, v[i], R, t_read[i]


def _fp_size(form, dv, du, ctx):
    law = form["size_law"]
    if law == "constant":
        return 1.0
    if law == "power":
        return (dv / ctx.vmax) ** form["size_exponent"]
    if law == "saturating":
        vs = form["size_scale_V"]
        return (1 - math.exp(-dv / vs)) / (1 - math.exp(-ctx.vmax / vs))
    return min(du / ctx.swing, 1.0)


def _turning_points(x0: float, xs: np.ndarray) -> list[float]:
    """The sub-sequence of ``xs`` that a rate-independent memory sees, starting from ``x0``."""
    pts: list[float] = []
    cur, direction = x0, 0
    for x in xs:
        d = np.sign(x - cur)
        if d == 0:
            continue
        if direction != 0 and d != direction:
            pts.append(cur)  # a local extremum
        direction, cur = d, x
    pts.append(cur)
    return [float(p) for p in pts]


def simulate(device, schedules, effects, seed, noise_um):
    """Simulate one session (see SPEC.md); returns one dict per run with t_s, v_V, y_um, dwell_s."""
    active = _parse(effects)
    session = _Session(device, active, int(seed))
    return [session.run(r, sch, noise_um) for r, sch in enumerate(schedules)]
