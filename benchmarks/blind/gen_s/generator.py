"""Blind generator ``gen_s``: unmodelled effects on the VO2 actuator rig, seen from the electronics bench.

Written from ``SPEC.md`` and ``base.py`` only.  The session is simulated as the
rig runs it: the heater driver applies each set-point, the film's temperature
(and with it the hysterons' input) follows, the beam deflects, the optical
lever and the PSD front-end turn the deflection into a number, and the data
logger averages a short burst of ADC samples and time-stamps it.

Every mechanism is a stage of that chain, applied in physical order::

    heater power -> temperature (thermal_lag, ambient_drift)
      -> film (interaction, accommodation)
      -> deflection (joule_power, reversible, creep)
      -> optical lever mount (backlash) and transients (first_point)
      -> PSD (optical_contrast, sensor_nonlinearity, gain_drift, baseline_drift)
      -> logger (noise, time stamps)

A mechanism with strength 0 is not applied at all, so with every strength 0 the
readings are exactly ``base.clean_outputs`` of each run.  See ``README.md``.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq
from scipy.signal import lfilter

from .. import base

LIBRARY: tuple[str, ...] = (
    "thermal_lag",
    "creep",
    "baseline_drift",
    "ambient_drift",
    "joule_power",
    "sensor_nonlinearity",
    "reversible",
    "interaction",
    "first_point",
    "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "optical_contrast")
FAMILIES: tuple[str, ...] = LIBRARY + OUTSIDE

# ----------------------------------------------------------------------------------------------
# The logger and the session (see README.md, "Data logger")
# ----------------------------------------------------------------------------------------------

#: ADC sample period of one reading of the burst (s); the burst is shortened for large K.
SAMPLE_PERIOD_S = 0.02
#: Longest burst (s): the sample period becomes ``MAX_BURST_S / K`` when K readings would not fit.
MAX_BURST_S = 0.4
#: Heater off between two runs (s), +- ``GAP_JITTER_S``.
GAP_S = 600.0
GAP_JITTER_S = 30.0
#: Grid step of the slow drift paths (s).
PATH_DT_S = 5.0
#: rms of the room's (package's) temperature wander at strength 1 (K).
AMBIENT_K = 0.1

_ROOT = 0x5E_4B1D_57
_TIMING, _NOISE, _PATH = 1, 2, 3

#: Scale of "clearly visible" at strength 1: a fraction of the device's output swing.
_VISIBLE = 0.01


def _stream(seed: int, *tags: int) -> np.random.Generator:
    return np.random.default_rng(
        np.random.SeedSequence([_ROOT, int(seed) % (2**63), *[int(t) for t in tags]])
    )


def _tag(family: str) -> int:
    return zlib.crc32(family.encode("utf-8"))


def _sat(s: float, slope: float, cap: float) -> float:
    """Monotone, continuous, ``slope * s`` for small ``s``, bounded by ``cap``; exactly 0 at 0."""
    if s <= 0.0:
        return 0.0
    return float(cap * -math.expm1(-s * slope / cap))


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _choice(rng: np.random.Generator, options, p=None):
    i = int(rng.choice(len(options), p=p))
    return options[i]


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> int:
    return 1 if rng.uniform() < p_plus else -1


# ----------------------------------------------------------------------------------------------
# Forms
# ----------------------------------------------------------------------------------------------


def _form_drift(rng: np.random.Generator, kinds, time_scale) -> dict:
    kind = _choice(rng, kinds)
    f: dict = {"kind": kind}
    lo, hi = time_scale
    if kind == "ou":
        f["tau_s"] = _logu(rng, lo, hi)
    elif kind == "random_walk":
        f["unit_time_s"] = _logu(rng, 1800.0, 10800.0)
    elif kind == "warmup":
        f["tau_s"] = _logu(rng, 300.0, 3600.0)
        f["wander_tau_s"] = _logu(rng, lo, hi)
        f["wander"] = _u(rng, 0.1, 0.5)
    elif kind == "periodic":
        f["period_s"] = _logu(rng, 900.0, 5400.0)
        f["wander_tau_s"] = _logu(rng, lo, hi)
        f["wander"] = _u(rng, 0.1, 0.5)
    elif kind == "flicker":
        f["alpha"] = _u(rng, 0.8, 2.0)
        f["f_min_Hz"] = 1.0 / _u(rng, 4 * 3600.0, 12 * 3600.0)
        f["f_max_Hz"] = 1.0 / _u(rng, 120.0, 600.0)
    return f


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism (JSON-safe): kernel, shape, time scales, signs...

    Does not depend on the strength, nor on other mechanisms present.
    """
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}")
    f: dict = {"family": family}
    if family == "thermal_lag":
        kind = _choice(rng, ("single", "two_path", "diffusive", "overshoot"))
        f["kind"] = kind
        if kind == "single":
            taus, w = [_logu(rng, 3.0, 120.0)], [1.0]
        elif kind == "two_path":
            share = _u(rng, 0.3, 0.8)
            taus, w = [_logu(rng, 2.0, 30.0), _logu(rng, 60.0, 900.0)], [share, 1.0 - share]
        elif kind == "diffusive":
            n = int(rng.integers(4, 8))
            t_lo, t_hi = _logu(rng, 0.5, 3.0), _logu(rng, 300.0, 3000.0)
            gamma = _u(rng, -0.5, 0.3)
            taus = list(np.geomspace(t_lo, t_hi, n))
            w = list(np.power(taus, gamma) / np.sum(np.power(taus, gamma)))
        else:  # overshoot: the heater's TCR at constant voltage gives a path with negative weight
            ratio = _u(rng, 0.3, 0.9)
            taus = [_logu(rng, 2.0, 40.0), _logu(rng, 60.0, 900.0)]
            if rng.uniform() < 0.5:  # fast lag, slow power sag (package warms the heater)
                w = [1.0 / (1.0 + ratio), -ratio / (1.0 + ratio)]
            else:  # fast power sag (heater self-heating), slow substrate lag
                w = [-ratio / (1.0 + ratio), 1.0 / (1.0 + ratio)]
        f["taus_s"] = [float(t) for t in taus]
        f["weights"] = [float(x) for x in w]
    elif family == "creep":
        kind = _choice(rng, ("single", "log_spectrum", "power_spectrum", "two_scale"))
        f["kind"] = kind
        if kind == "single":
            taus, w = [_logu(rng, 5.0, 1800.0)], [1.0]
        elif kind == "two_scale":
            share = _u(rng, 0.2, 0.8)
            taus, w = [_logu(rng, 2.0, 60.0), _logu(rng, 600.0, 10800.0)], [share, 1.0 - share]
        else:
            n = int(rng.integers(4, 8))
            taus = list(np.geomspace(_logu(rng, 2.0, 30.0), _logu(rng, 1800.0, 14400.0), n))
            gamma = 0.0 if kind == "log_spectrum" else _u(rng, -0.6, 0.4)
            w = list(np.power(taus, gamma) / np.sum(np.power(taus, gamma)))
        f["taus_s"] = [float(t) for t in taus]
        f["weights"] = [float(x) for x in w]
        f["source"] = _choice(rng, ("total", "phase"))
        f["sign"] = _sign(rng, 0.75)
        f["size_exponent"] = _u(rng, 0.6, 1.4)
        f["asymmetry"] = _u(rng, -0.4, 0.4) if rng.uniform() < 0.7 else 0.0
    elif family in ("baseline_drift", "gain_drift"):
        f.update(_form_drift(rng, ("ou", "random_walk", "warmup", "periodic", "flicker"), (600.0, 10800.0)))
    elif family == "ambient_drift":
        f.update(_form_drift(rng, ("ou", "random_walk", "warmup", "periodic", "flicker"), (900.0, 14400.0)))
    elif family == "joule_power":
        kind = _choice(rng, ("power", "tempco", "exponential", "saturating"))
        f["kind"] = kind
        if kind == "power":
            f["exponent"] = _u(rng, 1.6, 2.4)
        elif kind == "tempco":
            f["beta"] = _u(rng, -0.4, 0.8)
        elif kind == "exponential":
            f["kappa"] = _u(rng, -1.5, 2.0)
        else:
            f["kappa"] = _u(rng, 0.3, 2.0)
    elif family == "sensor_nonlinearity":
        f["kind"] = _choice(rng, ("tanh", "atan", "sinh", "exp"))
        f["centre_offset"] = _u(rng, -0.8, 0.8)
        f["range_ratio"] = _u(rng, 1.0, 2.0)
        f["sign"] = _sign(rng)
    elif family == "reversible":
        kind = _choice(rng, ("bump", "step", "poly", "onset"))
        f["kind"] = kind
        f["input"] = _choice(rng, ("heater", "temperature"))
        f["sign"] = _sign(rng)
        if kind == "bump":
            f["centre"], f["width"] = _u(rng, 0.35, 0.95), _u(rng, 0.04, 0.25)
        elif kind == "step":
            f["centre"], f["width"] = _u(rng, 0.4, 0.95), _u(rng, 0.03, 0.2)
        elif kind == "poly":
            f["coefficients"] = [float(c) for c in rng.normal(0.0, 1.0, 3)]
        else:
            f["centre"], f["width"] = _u(rng, 0.3, 0.9), _u(rng, 0.03, 0.15)
    elif family == "interaction":
        kind = _choice(rng, ("linear", "saturating", "asymmetric"))
        f["kind"] = kind
        f["sign"] = _sign(rng)
        f["reference"] = -1.0 if rng.uniform() < 0.4 else _u(rng, -1.0, 1.0)
        if kind == "saturating":
            f["kappa"] = _u(rng, 1.0, 3.0)
        elif kind == "asymmetric":
            f["asymmetry"] = _u(rng, -0.6, 0.6)
    elif family == "first_point":
        f["kind"] = _choice(rng, ("lag", "lead", "one_sided", "same_sign"))
        f["sign"] = _sign(rng)
        ratio = _u(rng, 0.3, 1.0)
        f["up_ratio"], f["down_ratio"] = (1.0, ratio) if rng.uniform() < 0.5 else (ratio, 1.0)
        if f["kind"] == "one_sided":
            f["side"] = _choice(rng, ("up", "down"))
        law = _choice(rng, ("constant", "power", "saturating"))
        f["size_law"] = law
        if law == "power":
            f["size_exponent"] = _u(rng, 0.3, 1.0)
        elif law == "saturating":
            f["size_scale_V"] = _u(rng, 0.1, 1.5)
        if rng.uniform() < 0.4:
            f["linger_ratio"], f["linger_points"] = 0.0, 0
        else:
            f["linger_ratio"], f["linger_points"] = _u(rng, 0.2, 0.6), int(rng.integers(1, 5))
    elif family == "backlash":
        kind = _choice(rng, ("play", "multi_play", "elastic_play"))
        f["kind"] = kind
        if kind == "multi_play":
            n = int(rng.integers(2, 6))
            widths = np.sort(rng.uniform(0.2, 1.0, n))
            widths = widths / widths[-1]
            f["widths"] = [float(x) for x in widths]
            f["weights"] = [float(x) for x in rng.dirichlet(np.ones(n))]
        elif kind == "elastic_play":
            f["compliance"] = _u(rng, 0.1, 0.5)
    elif family == "accommodation":
        f["pattern"] = _choice(rng, ("fatigue", "narrowing", "shift"))
        f["sign"] = _sign(rng, 0.7)
        f["tilt"] = _u(rng, -0.3, 0.3)
        law = _choice(rng, ("saturating", "log", "power"))
        f["law"] = law
        if law == "saturating":
            f["n0"] = _u(rng, 3.0, 40.0)
        elif law == "log":
            f["n0"] = _u(rng, 1.0, 10.0)
        else:
            f["gamma"] = _u(rng, 0.3, 1.0)
    elif family == "optical_contrast":
        f["contrast"] = _u(rng, 0.15, 0.6) if rng.uniform() < 0.7 else _u(rng, -0.35, -0.1)
        f["mixing"] = _choice(rng, ("linear", "percolation"))
        if f["mixing"] == "percolation":
            f["threshold"], f["width"] = _u(rng, 0.3, 0.7), _u(rng, 0.05, 0.2)
        f["imbalance_position"] = _u(rng, -1.5, 1.5)
    return f


# ----------------------------------------------------------------------------------------------
# Device scales
# ----------------------------------------------------------------------------------------------


class _Scales:
    """Output range of the clean device on its major loop, and the steepest phase slope."""

    def __init__(self, device: base.BaseDevice) -> None:
        self.device = device
        vmin, vmax = device.v_min_V, device.v_max_V
        sweep = np.concatenate([np.linspace(vmin, vmax, 61), np.linspace(vmax, vmin, 61)[1:]])
        h = device.hysteresis()
        p = np.array([h.move(x) for x in sweep])
        u = np.array([device.output(pp, x) for pp, x in zip(p, sweep)])
        self.loop_u, self.loop_p = u, p  # the clean major loop
        self.umin, self.umax = float(u.min()), float(u.max())
        self.swing = max(self.umax - self.umin, 1e-9)
        self.mid = 0.5 * (self.umin + self.umax)
        self.half = 0.5 * self.swing
        self.A = max(device.phase_swing_um, 1e-12)
        self.vmin, self.vmax = vmin, vmax
        self.vspan = vmax - vmin
        self._slope = None

    @property
    def slope_max(self) -> float:
        """Largest |d phase / d x| (um/V) on the major loop (bounds every branch's slope)."""
        if self._slope is None:
            h = self.device.hysteresis()
            xs = np.concatenate([np.linspace(self.vmin, self.vmax, 241), np.linspace(self.vmax, self.vmin, 241)[1:]])
            p = np.array([h.move(x) for x in xs])
            self._slope = float(np.max(np.abs(np.diff(p)) / np.abs(np.diff(xs)))) + 1e-9
        return self._slope


# ----------------------------------------------------------------------------------------------
# Drift paths (baseline, gain, ambient): one realisation per run, normalised to rms ~ 1
# ----------------------------------------------------------------------------------------------


def _ou(rng: np.random.Generator, n: int, tau: float) -> np.ndarray:
    a = math.exp(-PATH_DT_S / tau)
    c = math.sqrt(1.0 - a * a)
    e = rng.standard_normal(n)
    e[0] /= c  # stationary start
    return lfilter([c], [1.0, -a], e)


def _drift_path(form: dict, rng: np.random.Generator, t_end: float):
    n = int(math.ceil(max(t_end, 0.0) / PATH_DT_S)) + 2
    t = np.arange(n) * PATH_DT_S
    kind = form["kind"]
    if kind == "ou":
        x = _ou(rng, n, form["tau_s"])
    elif kind == "random_walk":
        e = rng.standard_normal(n)
        e[0] = 0.0
        x = np.cumsum(e) * math.sqrt(PATH_DT_S / form["unit_time_s"])
    elif kind == "warmup":
        amp = rng.standard_normal()
        x = amp * -np.expm1(-t / form["tau_s"]) + form["wander"] * _ou(rng, n, form["wander_tau_s"])
    elif kind == "periodic":
        period = form["period_s"] * (1.0 + 0.1 * rng.uniform(-1.0, 1.0))
        phase = rng.uniform(0.0, 2.0 * math.pi)
        amp = rng.uniform(0.7, 1.3)
        x = math.sqrt(2.0) * amp * np.sin(2.0 * math.pi * t / period + phase)
        x = x + form["wander"] * _ou(rng, n, form["wander_tau_s"])
    elif kind == "flicker":
        freqs = np.geomspace(form["f_min_Hz"], form["f_max_Hz"], 24)
        a = freqs ** (-form["alpha"] / 2.0)
        a = a / math.sqrt(float(np.sum(a * a)))
        amps = a * rng.rayleigh(1.0, freqs.size)
        phases = rng.uniform(0.0, 2.0 * math.pi, freqs.size)
        x = np.sin(2.0 * math.pi * np.outer(t, freqs) + phases) @ amps
    else:
        raise ValueError(f"unknown drift kind {kind!r}")

    def at(times):
        return np.interp(np.asarray(times, dtype=float), t, x)

    return at


# ----------------------------------------------------------------------------------------------
# Static shapes
# ----------------------------------------------------------------------------------------------


def _joule_shape(form: dict, z):
    """Normalised power-driven bimorph law ``Phi(z)``, ``z = v / v_max``, ``Phi(0) = 0``, ``Phi(1) = 1``."""
    z = np.clip(np.asarray(z, dtype=float), 0.0, None)
    kind = form["kind"]
    q = z * z  # power, temperature rise
    if kind == "power":
        return np.power(z, form["exponent"])
    if kind == "tempco":
        b = form["beta"]
        return (q + b * q * q) / (1.0 + b)
    if kind == "exponential":
        k = form["kappa"]
        if abs(k) < 1e-9:
            return q
        return np.expm1(k * q) / math.expm1(k)
    k = form["kappa"]
    return np.tanh(k * q) / math.tanh(k)


def _reversible_shape(form: dict, q):
    """Normalised anhysteretic shape on ``q`` in [0, 1]: ``rho(0) = 0``, ``max |rho| = 1`` on [0, 1]."""

    def raw(x):
        x = np.asarray(x, dtype=float)
        kind = form["kind"]
        if kind == "bump":
            return np.exp(-0.5 * ((x - form["centre"]) / form["width"]) ** 2)
        if kind == "step":
            return np.tanh((x - form["centre"]) / form["width"])
        if kind == "poly":
            c = form["coefficients"]
            return c[0] * x**2 + c[1] * x**3 + c[2] * x**4
        w = form["width"]
        return w * np.logaddexp(0.0, (x - form["centre"]) / w)

    grid = np.linspace(0.0, 1.0, 401)
    r0 = raw(0.0)
    norm = float(np.max(np.abs(raw(grid) - r0))) or 1.0
    return form["sign"] * (raw(q) - r0) / norm


def _nl(kind: str, lam: float, sgn: int, z):
    z = np.asarray(z, dtype=float)
    if lam <= 0.0:
        return z
    if kind == "tanh":
        return np.tanh(lam * z) / lam
    if kind == "atan":
        return np.arctan(lam * z) / lam
    if kind == "sinh":
        return np.sinh(lam * z) / lam
    return np.expm1(sgn * lam * z) / (sgn * lam)


def _affine_residual(x: np.ndarray, y: np.ndarray) -> float:
    M = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(M, y, rcond=None)
    return float(np.max(np.abs(y - M @ coef)))


# ----------------------------------------------------------------------------------------------
# Mechanism objects, built from (form, strength) and the device
# ----------------------------------------------------------------------------------------------


class _ThermalLag:
    def __init__(self, form: dict, s: float) -> None:
        self.taus = np.asarray(form["taus_s"], dtype=float)
        w = np.asarray(form["weights"], dtype=float)
        w = w / max(float(np.sum(np.abs(w))), 1e-12)
        self.w = _sat(s, 0.015, 0.6) * w
        self.W = float(np.sum(self.w))
        self.state = np.zeros_like(self.taus)  # slow paths' rise (K)

    def rise(self, P: float, offsets: np.ndarray) -> np.ndarray:
        decay = np.exp(-np.outer(offsets, 1.0 / self.taus))
        slow = P + (self.state[None, :] - P) * decay
        return np.maximum((1.0 - self.W) * P + slow @ self.w, 0.0)

    def advance(self, P: float, dt: float) -> None:
        self.state = P + (self.state - P) * np.exp(-dt / self.taus)


class _Interaction:
    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        self.form = form
        kind = form["kind"]
        z0 = form["reference"]
        if kind == "linear":
            self.phi = lambda z: z - z0
            dmax = 1.0
        elif kind == "saturating":
            k = form["kappa"]
            self.phi = lambda z: np.tanh(k * (z - z0)) / k
            dmax = 1.0
        else:
            a = form["asymmetry"]
            self.phi = lambda z: (z - z0) * (1.0 + a * np.sign(z - z0))
            dmax = 1.0 + abs(a)
        loop_gain = _sat(s, 0.03, 0.5)
        # G(p) = g_V * phi(p / A): loop gain g_V * phi' / A * slope <= loop_gain
        self.g_V = form["sign"] * loop_gain * sc.A / (dmax * sc.slope_max)
        ends = [float(self.phi(-1.5)), float(self.phi(1.5))]
        self.gmin = self.g_V * min(ends) if self.g_V > 0 else self.g_V * max(ends)
        self.gmax = self.g_V * max(ends) if self.g_V > 0 else self.g_V * min(ends)
        self.A = sc.A

    def G(self, p: float) -> float:
        return float(self.g_V * self.phi(np.clip(p / self.A, -1.5, 1.5)))


class _Accommodation:
    def __init__(self, form: dict, s: float, device: base.BaseDevice) -> None:
        alpha, beta = device.grid.cell_centres()
        dens = np.asarray(device.density_um, dtype=float)
        wts = dens / max(float(np.sum(dens)), 1e-12)
        centre = 0.5 * (alpha + beta)
        width = alpha - beta
        span = device.v_max_V - device.v_min_V
        c_rel = (centre - float(wts @ centre)) / span
        if form["pattern"] == "fatigue":
            m = -(1.0 + form["tilt"] * np.tanh(c_rel / max(math.sqrt(float(wts @ c_rel**2)), 1e-12)))
            m = m / float(np.max(np.abs(m)))
        else:
            raw = (float(wts @ width) - width) if form["pattern"] == "narrowing" else c_rel
            raw = raw - float(wts @ raw)
            m = np.tanh(raw / max(math.sqrt(float(wts @ raw**2)), 1e-12))  # ~ +-0.76 over the transition
            m = m - float(wts @ m)  # the transformation's total amplitude is kept
        m = m / max(1.0, float(np.max(np.abs(m))))  # |m| <= 1: with a * law <= 0.7 no weight turns negative
        m = form["sign"] * m
        self.pattern_device = replace(device, density_um=dens * m)
        self.form = form
        self.a = _sat(s, 0.03, 0.35)

    def law(self, N: float) -> float:
        f = self.form
        ref = 40.0
        if f["law"] == "saturating":
            c = -math.expm1(-N / f["n0"]) / -math.expm1(-ref / f["n0"])
        elif f["law"] == "log":
            c = math.log1p(N / f["n0"]) / math.log1p(ref / f["n0"])
        else:
            c = (N / ref) ** f["gamma"]
        return 2.0 * math.tanh(c / 2.0)


class _Film:
    """The phase transition, with the mean-field interaction and the use-dependent weights."""

    def __init__(self, device, sc: _Scales, inter: _Interaction | None, acc: _Accommodation | None) -> None:
        self.h = device.hysteresis()
        self.acc = acc
        self.hm = acc.pattern_device.hysteresis() if acc else None
        self.inter = inter
        self.A = sc.A
        self.N = 0.0  # equivalent full cycles of the film
        self.x = device.v_min_V  # last input felt before the interaction
        self.offset = 0.0  # interaction's shift of the hysterons' input at the last move (V)
        self.pb = self.h.value()
        self.pm = self.hm.value() if self.hm else 0.0

    def _eff(self, pb: float, pm: float) -> float:
        if self.acc is None:
            return pb
        return pb + self.acc.a * self.acc.law(self.N) * pm

    def value(self) -> float:
        return self._eff(self.pb, self.pm)

    def move(self, x: float) -> float:
        x = float(x)
        z = x
        if self.inter is not None:
            it = self.inter

            def f(zz):
                pb = self.h.peek(zz)
                pm = self.hm.peek(zz) if self.hm else 0.0
                return zz - x - it.G(self._eff(pb, pm))

            # fixed-point iteration from the last offset (contraction: loop gain < 1), Brent if slow
            zz = x + self.offset
            for _ in range(8):
                z_new = zz - f(zz)
                if abs(z_new - zz) < 1e-12:
                    break
                zz = z_new
            else:
                lo, hi = x + it.gmin - 1e-9, x + it.gmax + 1e-9
                z_new = brentq(f, lo, hi, xtol=1e-12, rtol=1e-14, maxiter=200)
            z = z_new
            self.offset = z - x
        pb = self.h.move(z)
        if self.hm is not None:
            self.pm = self.hm.move(z)
        self.N += abs(pb - self.pb) / (4.0 * self.A)
        self.pb = pb
        self.x = x
        return self.value()


class _Creep:
    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        self.taus = np.asarray(form["taus_s"], dtype=float)
        w = np.asarray(form["weights"], dtype=float)
        self.w = _sat(s, 0.03, 0.5) * w / max(float(np.sum(np.abs(w))), 1e-12)
        self.asym = np.where(self.taus <= 60.0, form["asymmetry"], 0.0)
        self.q = form["size_exponent"]
        self.S = sc.swing
        self.sign = form["sign"]
        self.source = form["source"]
        self.r = np.zeros_like(self.taus)  # unrelaxed parts (um), referenced to the last change time

    def change(self, d: float) -> None:
        if d == 0.0:
            return
        sg = 1.0 if d > 0 else -1.0
        g = sg * abs(d) ** self.q * self.S ** (1.0 - self.q)
        self.r = self.r + self.w * g * (1.0 + self.asym * sg)

    def value(self, dt: float) -> float:
        return float(-self.sign * np.sum(self.r * np.exp(-dt / self.taus)))

    def advance(self, dt: float) -> None:
        self.r = self.r * np.exp(-dt / self.taus)


class _Backlash:
    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        delta = _sat(s, 2.0 * _VISIBLE * sc.swing, 0.3 * sc.swing)
        kind = form["kind"]
        if kind == "multi_play":
            self.widths = delta * np.asarray(form["widths"], dtype=float)
            self.weights = np.asarray(form["weights"], dtype=float)
        else:
            self.widths = np.array([delta])
            self.weights = np.array([1.0])
        self.kappa = form.get("compliance", 0.0) if kind == "elastic_play" else 0.0
        self.y = None
        self.u_prev = None

    def rest(self, u: float) -> float:
        """At rest after the heater was off (the last motion was downward)."""
        if self.y is None:
            self.y = u + 0.5 * self.widths
            self.u_prev = u
        return self.apply(u)

    def apply(self, u: float) -> float:
        y = self.y + self.kappa * (u - self.u_prev)
        self.y = np.clip(y, u - 0.5 * self.widths, u + 0.5 * self.widths)
        self.u_prev = u
        return float(self.weights @ self.y)


class _FirstPoint:
    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        amp = s * _VISIBLE * sc.swing
        kind, sg = form["kind"], form["sign"]
        up, dn = form["up_ratio"], form["down_ratio"]
        if kind == "lag":
            self.d_up, self.d_dn = -up, dn
        elif kind == "lead":
            self.d_up, self.d_dn = up, -dn
        elif kind == "same_sign":
            self.d_up, self.d_dn = up, dn
        else:
            self.d_up, self.d_dn = (1.0, 0.0) if form["side"] == "up" else (0.0, 1.0)
        self.d_up *= sg * amp
        self.d_dn *= sg * amp
        self.form = form
        self.vspan = sc.vspan

    def size(self, dv: float) -> float:
        law = self.form["size_law"]
        if law == "constant":
            return 1.0
        if law == "power":
            return (min(dv, self.vspan) / self.vspan) ** self.form["size_exponent"]
        a = self.form["size_scale_V"]
        return -math.expm1(-dv / a) / -math.expm1(-self.vspan / a)

    def offsets(self, v: np.ndarray) -> np.ndarray:
        """Offsets of one run's readings; before the run the heater was lowered to 0 V (direction down)."""
        out = np.zeros(v.size)
        last_dir, k, e0 = -1, None, 0.0
        prev = 0.0
        rho, n_l = self.form["linger_ratio"], self.form["linger_points"]
        for n, vn in enumerate(v):
            dv = float(vn) - prev
            prev = float(vn)
            d = 0 if abs(dv) <= 1e-12 else (1 if dv > 0 else -1)
            if d != 0 and d != last_dir:
                last_dir = d
                k = 0
                e0 = (self.d_up if d > 0 else self.d_dn) * self.size(abs(dv))
            elif k is not None:
                k += 1
            if k is not None and k <= n_l:
                out[n] = e0 * (rho**k if k > 0 else 1.0)
        return out


class _SensorNL:
    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        self.kind = form["kind"]
        self.sgn = form["sign"]
        self.c = sc.mid + form["centre_offset"] * sc.half
        self.L = (sc.half + abs(form["centre_offset"]) * sc.half) * form["range_ratio"]
        u = np.linspace(sc.umin, sc.umax, 201)
        target = _VISIBLE * sc.swing

        def dev(lam):
            return _affine_residual(u, self._f(u, lam)) - target

        lam_hi = 20.0
        lam1 = lam_hi if dev(lam_hi) < 0 else brentq(dev, 1e-6, lam_hi, xtol=1e-10)
        cap = 3.0 if self.kind in ("sinh", "exp") else 10.0
        # odd laws (tanh, atan, sinh) deviate as lam**2, the one-sided exponential as lam: make the
        # deviation grow about linearly with the strength
        growth = math.sqrt(s) if self.kind in ("tanh", "atan", "sinh") else s
        self.lam = _sat(growth, lam1, max(cap, 2.0 * lam1))

    def _f(self, u, lam):
        return self.c + self.L * _nl(self.kind, lam, self.sgn, (np.asarray(u) - self.c) / self.L)

    def __call__(self, u: float) -> float:
        return float(self._f(u, self.lam))


class _OpticalContrast:
    """The PSD normalises by the total photocurrent; dark/offset currents and the VO2's reflectance change."""

    def __init__(self, form: dict, s: float, sc: _Scales) -> None:
        self.rho = form["contrast"]
        self.form = form
        self.uD = sc.mid + form["imbalance_position"] * sc.half
        self.A = sc.A
        target = _VISIBLE * sc.swing
        rf = self.rho * np.array([self.fraction(p) for p in sc.loop_p])
        lever = np.abs(rf * (sc.loop_u - self.uD))  # deviation = sigma * lever / (1 + sigma + rf)

        def dev(sig):
            return float(np.max(sig * lever / (1.0 + sig + rf))) - target

        # sigma (dark/offset currents over the signal current) giving ~1 % of the swing at strength 1
        sigma1 = 5.0 if dev(5.0) < 0 else brentq(dev, 0.0, 5.0, xtol=1e-12)
        self.sigma = s * sigma1

    def fraction(self, p: float) -> float:
        f = min(max((p + self.A) / (2.0 * self.A), 0.0), 1.0)
        if self.form["mixing"] == "percolation":
            fc, w = self.form["threshold"], self.form["width"]
            lg = lambda x: 1.0 / (1.0 + math.exp(-x))  # noqa: E731
            lo, hi = lg(-fc / w), lg((1.0 - fc) / w)
            f = (lg((f - fc) / w) - lo) / (hi - lo)
        return f

    def __call__(self, y: float, p: float) -> float:
        rf = self.rho * self.fraction(p)
        return y + rf * self.sigma * (y - self.uD) / (1.0 + self.sigma + rf)


# ----------------------------------------------------------------------------------------------
# The session
# ----------------------------------------------------------------------------------------------


def _timing(seed: int, r: int, dwell: np.ndarray, K: int):
    """Set-point change times (n + 1: the last is the heater-off time), reading times, gap before the run."""
    rng = _stream(seed, _TIMING, r)
    gap = GAP_S + float(rng.uniform(-GAP_JITTER_S, GAP_JITTER_S))
    n = dwell.size
    trigger = rng.uniform(0.002, 0.015, n)  # logger trigger latency after the dwell
    overhead = rng.uniform(0.005, 0.040, n)  # transfer + driver command latency after the burst
    ts = min(SAMPLE_PERIOD_S, MAX_BURST_S / max(K, 1))
    burst = K * ts
    step = dwell + trigger + burst + overhead
    t_set = np.concatenate([[0.0], np.cumsum(step)])
    t_read = t_set[:-1] + dwell + trigger + 0.5 * burst
    return t_set, t_read, gap


def _turning_points(xs: list[float]) -> list[float]:
    """Turning points of a path (its first point is where the film is), then its end point."""
    seq = [xs[0]]
    for x in xs[1:]:
        if x != seq[-1]:
            seq.append(x)
    out = []
    for i in range(1, len(seq) - 1):
        if (seq[i] - seq[i - 1]) * (seq[i + 1] - seq[i]) < 0:
            out.append(seq[i])
    out.append(xs[-1])
    return out


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session.

    device:    base.BaseDevice
    schedules: list of dicts, one per run in order, each {"v_V": (n,), "dwell_s": (n,), "readings": K}
    effects:   list of (family, form, strength) with strength >= 0 (0: the mechanism is absent)
    seed:      int; every random choice of the realisation (a drift's path, the noise, the timing) comes from it
    noise_um:  rms noise of one recorded point (the average of K readings), or None for noise-free outputs
    returns:   one dict per run: {"t_s", "v_V", "y_um", "dwell_s"}, each (n,)
    """
    active: dict[str, tuple[dict, float]] = {}
    seen = set()
    for family, form, strength in effects:
        if family not in FAMILIES:
            raise ValueError(f"unknown family {family!r}")
        if family in seen:
            raise ValueError(f"family {family!r} given twice")
        seen.add(family)
        s = float(strength)
        if not (s >= 0.0) or not math.isfinite(s):
            raise ValueError(f"strength of {family!r} must be finite and >= 0, got {strength!r}")
        if s > 0.0:
            active[family] = (dict(form), s)

    sc = _Scales(device) if active else None
    vmin, vmax = device.v_min_V, device.v_max_V

    def get(name):
        return active.get(name)

    lag = _ThermalLag(*get("thermal_lag")) if get("thermal_lag") else None
    inter = _Interaction(*get("interaction"), sc) if get("interaction") else None
    acc = _Accommodation(*get("accommodation"), device) if get("accommodation") else None
    creep = _Creep(*get("creep"), sc) if get("creep") else None
    backlash = _Backlash(*get("backlash"), sc) if get("backlash") else None
    first = _FirstPoint(*get("first_point"), sc) if get("first_point") else None
    snl = _SensorNL(*get("sensor_nonlinearity"), sc) if get("sensor_nonlinearity") else None
    contrast = _OpticalContrast(*get("optical_contrast"), sc) if get("optical_contrast") else None
    joule = get("joule_power")
    if joule:
        jform, js = joule
        zg = np.linspace(0.0, 1.0, 201)
        jdev = float(np.max(np.abs(_joule_shape(jform, zg) - zg)))
        mu1 = _VISIBLE * sc.swing / max(abs(device.thermal_um_per_V) * (vmax - vmin) * jdev, 1e-12)
        mu = _sat(js, mu1, 1.0)
    rev = get("reversible")
    amb = get("ambient_drift")
    base_d = get("baseline_drift")
    gain_d = get("gain_drift")
    amb_K = AMBIENT_K * amb[1] if amb else 0.0
    base_um = 0.5 * _VISIBLE * base_d[1] * sc.swing if base_d else 0.0
    if gain_d:
        eps1 = min(0.5 * _VISIBLE * sc.swing / max(abs(sc.umin), abs(sc.umax), 1e-9), 0.02)
        gain_eps = gain_d[1] * eps1
    thermal = lag is not None or amb is not None

    film = _Film(device, sc, inter, acc) if active else None
    k2 = device.kelvin_per_V2

    def v_thermal_map(vth: float) -> float:
        if not joule:
            return vth
        z = (vth - vmin) / (vmax - vmin)
        return float((1.0 - mu) * vth + mu * (vmin + (vmax - vmin) * _joule_shape(jform, z)))

    def deflection(p: float, v: float, x: float, vth: float) -> float:
        u = device.output(p, v_thermal_map(vth))
        if rev:
            q = (v if rev[0]["input"] == "heater" else x) - vmin
            u += rev[1] * _VISIBLE * sc.swing * float(_reversible_shape(rev[0], q / (vmax - vmin)))
        return u

    def move_path(xs: list[float]) -> float:
        p = film.value()
        for x in _turning_points([film.x] + list(xs)):
            p = film.move(x)
        return p

    outputs = []
    for r, sched in enumerate(schedules):
        v = np.asarray(sched["v_V"], dtype=float).reshape(-1)
        dwell = np.asarray(sched["dwell_s"], dtype=float).reshape(-1)
        if v.shape != dwell.shape:
            raise ValueError("v_V and dwell_s must have the same length")
        K = int(sched.get("readings", 1))
        t_set, t_read, gap = _timing(seed, r, dwell, K)
        n = v.size
        t_end = float(t_set[-1]) + PATH_DT_S

        if not active:
            h = device.hysteresis()
            y = np.array([device.output(h.move(x), x) for x in v])
        else:
            amb_path = _drift_path(amb[0], _stream(seed, _PATH, _tag("ambient_drift"), r), t_end) if amb else None
            base_path = _drift_path(base_d[0], _stream(seed, _PATH, _tag("baseline_drift"), r), t_end) if base_d else None
            gain_path = _drift_path(gain_d[0], _stream(seed, _PATH, _tag("gain_drift"), r), t_end) if gain_d else None

            def film_input(P: float, offsets: np.ndarray, t0: float):
                """Hysteron inputs (V) and the thermal term's equivalent voltage along an interval."""
                rise = lag.rise(P, offsets) if lag is not None else np.full(offsets.size, P)
                dT = amb_K * amb_path(t0 + offsets) if amb is not None else 0.0
                xs = device.equivalent_voltage(rise + dT)
                vth = device.equivalent_voltage(rise) if lag is not None else None
                return xs, vth

            # -- the heater has been off: a long time before run 0, the gap before later runs
            if r == 0:
                if amb is not None:
                    xs, _ = film_input(0.0, np.array([0.0]), 0.0)
                    move_path([float(xs[0])])
            else:
                offs = np.concatenate([[0.0], np.geomspace(0.05, gap, 12)]) if lag is not None else np.array([gap])
                # the room during the gap: this run's path, held at its start value
                xs, _ = film_input(0.0, offs, -gap)
                move_path([float(x) for x in xs])
            if lag is not None:
                if r > 0:
                    lag.advance(0.0, gap)
                vth_rest = float(device.equivalent_voltage(lag.rise(0.0, np.array([0.0]))[0]))
            else:
                vth_rest = vmin
            p_rest = film.value()
            u_rest = deflection(p_rest, vmin, film.x, vth_rest)
            src_rest = (u_rest if creep.source == "total" else p_rest) if creep else 0.0
            if creep is not None:
                if r > 0:
                    creep.change(src_rest - prev_src)
                    creep.advance(gap)
                prev_src = src_rest
            if backlash is not None:
                backlash.rest(u_rest + (creep.value(0.0) if creep else 0.0))

            fp = first.offsets(v) if first is not None else None
            y = np.empty(n)
            for i in range(n):
                vi = float(v[i])
                P = k2 * vi * vi
                T = float(t_read[i] - t_set[i])
                if thermal:
                    if lag is not None:
                        offs = np.concatenate([[0.0], np.geomspace(min(0.05, T), T, 12)])
                    else:
                        offs = np.array([T])
                    xs, vths = film_input(P, offs, float(t_set[i]))
                    p = move_path([float(x) for x in xs])
                    x_read = float(xs[-1])
                    vth = float(vths[-1]) if lag is not None else vi
                else:
                    p = film.move(vi)
                    x_read, vth = vi, vi
                u = deflection(p, vi, x_read, vth)
                if creep is not None:
                    src = u if creep.source == "total" else p
                    creep.change(src - prev_src)
                    prev_src = src
                    u = u + creep.value(T)
                    creep.advance(float(t_set[i + 1] - t_set[i]))
                if lag is not None:
                    lag.advance(P, float(t_set[i + 1] - t_set[i]))
                if backlash is not None:
                    u = backlash.apply(u)
                if fp is not None:
                    u = u + fp[i]
                yy = snl(u) if snl is not None else u
                if contrast is not None:
                    yy = contrast(yy, p)
                if gain_d:
                    yy = yy * (1.0 + gain_eps * float(gain_path(t_read[i])))
                if base_d:
                    yy = yy + base_um * float(base_path(t_read[i]))
                y[i] = yy

        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * _stream(seed, _NOISE, r).standard_normal(n)
        outputs.append(
            {"t_s": t_read.copy(), "v_V": v.copy(), "y_um": y, "dwell_s": (t_read - t_set[:-1])}
        )
    return outputs


__all__ = ["LIBRARY", "OUTSIDE", "FAMILIES", "draw_form", "simulate"]
