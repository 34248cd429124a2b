"""Blind generator ``gen_r``: unmodelled effects on a VO2 microactuator, written by a thin-film grower.

Everything is built on :mod:`benchmarks.blind.base` (the clean device) and
follows ``SPEC.md``.  The simulation is event driven, in *session time*: the
two (or more) runs follow each other with the heater off for about ten
minutes in between, so that slow states (the package temperature, the
beam's visco-elastic memory, the play of the lever's mount, the film's
cycling history) carry over from one run to the next, while drifts are
drawn afresh for every run.

Physical order of one reading (``SPEC``: temperature -> film -> deflection ->
sensor)::

    heater power --(thermal_lag, ambient_drift)--> film temperature x (equivalent V)
                 --(interaction, accommodation)--> phase part (Preisach, base.Hysteresis)
    deflection u = base output (+ joule_power, reversible)
                 --(creep, first_point, backlash)--> mechanical deflection
    reading y = baseline(t) + gain(t) * reflectance(phase) * F(u_mech)   (+ noise)

Random streams: every random choice of a realisation comes from
``numpy.random.SeedSequence([TAG, seed, run, purpose])``: one stream per run
for the timing, one per run for the noise, one per run and mechanism for a
drift's path.  Nothing is drawn from a stream shared in sequence by the runs,
so a run never depends on the runs that follow it (prefix stability), and no
realisation depends on the strengths or on which other mechanisms are present.

Logger: each run's dict carries ``t_s`` (the time of the middle of the
reading burst, from the run's first set-point change), ``v_V``, ``y_um`` and
``dwell_s`` (time from the set-point change to the middle of the burst).
"""

from __future__ import annotations

import dataclasses
import math
import zlib

import numpy as np

from .. import base

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "phase_reflectance")

_TAG = 77_190_523          # this generator's stream tag
_SAMPLE_PERIOD_S = 0.01    # PSD sampling period inside a burst (100 Hz)
_GAP_S = 600.0             # nominal heater-off time between runs
_HORIZON_S = 4.0 * 3600.0  # nominal run length used to normalise drift paths
_ACC_CYCLES = 100.0        # reference number of full transformation cycles (about one identification run)

# Strength-1 scales ("about 1 % of the output swing"), calibrated on drawn devices.
_SCALE = {
    "thermal_lag": 0.006,        # fraction of the steady rise carried by slow paths
    "creep": 0.02,               # delayed compliance / instantaneous deflection change
    "baseline_drift": 0.008,     # rms offset / swing
    "ambient_drift": 0.2,        # rms ambient excursion (K)
    "joule_power": 0.012,        # max thermal-term deviation / swing
    "sensor_nonlinearity": 0.015,  # max deviation / swing over the output range
    "reversible": 0.012,         # max anhysteretic term / swing
    "interaction": 0.04,         # loop gain
    "first_point": 0.02,         # first-point offset / swing
    "gain_drift": 0.015,         # rms relative gain excursion
    "backlash": 0.008,           # play half-width / swing
    "accommodation": 0.03,       # relative weight change at the reference cycle count
    "phase_reflectance": 0.02,   # relative gain change over the whole transition
}


# ----------------------------------------------------------------------------- streams


def _code(name: str) -> int:
    return zlib.crc32(name.encode("utf-8")) & 0x7FFFFFFF


def _stream(seed: int, run: int, purpose: str) -> np.random.Generator:
    s = int(seed) & 0xFFFFFFFFFFFFFFFF
    return np.random.default_rng(np.random.SeedSequence([_TAG, s, int(run), _code(purpose)]))


def _u(rng, lo, hi) -> float:
    return float(rng.uniform(lo, hi))


def _logu(rng, lo, hi) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _pick(rng, options, p=None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


# ----------------------------------------------------------------------------- forms


def _drift_form(rng, with_hvac: bool) -> dict:
    kinds = ["wander", "warmup", "trend", "hvac"] if with_hvac else ["wander", "warmup", "trend"]
    w = rng.dirichlet(np.full(len(kinds), 0.8))
    form = {
        "weights": {k: float(x) for k, x in zip(kinds, w)},
        "corr_time_s": _logu(rng, 600.0, 7200.0),
        "spectral_slope": _u(rng, 2.0, 4.0),
        "warmup_tau_s": _logu(rng, 300.0, 3600.0),
        "start": _pick(rng, ["zero", "free"]),
    }
    if with_hvac:
        form["hvac_period_s"] = _logu(rng, 900.0, 2700.0)
        form["hvac_shape"] = _pick(rng, ["sine", "triangle", "sawtooth"])
    return form


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe).

    The form fixes the *kind* of the effect on this device (kernel, shape, time
    scales, signs, asymmetries); it does not depend on the strength nor on the
    other mechanisms present.  Drift paths themselves are realised from the
    session seed in :func:`simulate`.
    """
    f: dict = {"family": family, "amplitude": _u(rng, 0.6, 1.6)}
    if family == "thermal_lag":
        n = int(rng.integers(1, 4))
        taus = sorted(_logu(rng, 3.0, 1800.0) for _ in range(n))
        fr = rng.dirichlet(np.ones(n))
        mode = _pick(rng, ["lag", "overshoot", "mixed"], p=[0.6, 0.15, 0.25])
        if mode == "lag":
            signs = [1.0] * n
        elif mode == "overshoot":
            signs = [-1.0] * n
        else:
            signs = [float(s) for s in rng.choice([-1.0, 1.0], size=n)]
            if n > 1 and len(set(signs)) == 1:
                signs[-1] = -signs[0]
        f.update(taus_s=[float(t) for t in taus], fractions=[float(x) for x in fr],
                 signs=signs, mode=mode)
    elif family == "creep":
        kernel = _pick(rng, ["single", "double", "spectrum"])
        if kernel == "single":
            taus, w = [_logu(rng, 5.0, 3600.0)], [1.0]
        elif kernel == "double":
            taus = [_logu(rng, 3.0, 120.0), _logu(rng, 600.0, 10800.0)]
            x = _u(rng, 0.2, 0.8)
            w = [x, 1.0 - x]
        else:
            lo, hi = _logu(rng, 2.0, 30.0), _logu(rng, 1800.0, 14400.0)
            beta = _u(rng, -0.4, 0.4)
            taus = list(np.geomspace(lo, hi, 6))
            w = np.power(np.asarray(taus) / lo, beta)
            w = list(w / w.sum())
        response = _pick(rng, ["linear", "power", "saturating"])
        f.update(kernel=kernel, taus_s=[float(t) for t in taus], weights=[float(x) for x in w],
                 response=response, exponent=_u(rng, 0.6, 1.6),
                 saturation=_u(rng, 0.15, 0.6),
                 down_over_up=_logu(rng, 0.4, 2.5) if rng.random() < 0.5 else 1.0,
                 sign=1.0 if rng.random() < 0.75 else -1.0)
    elif family in ("baseline_drift", "gain_drift"):
        f.update(_drift_form(rng, with_hvac=False))
    elif family == "ambient_drift":
        f.update(_drift_form(rng, with_hvac=True))
    elif family == "joule_power":
        f.update(kind=_pick(rng, ["power", "exponent", "tcoef"]), exponent=_u(rng, 1.5, 2.5),
                 tcoef=_u(rng, -0.5, 1.0))
    elif family == "sensor_nonlinearity":
        f.update(kind=_pick(rng, ["cubic", "tanh", "sinh", "quadratic", "mixed"]),
                 sign=float(rng.choice([-1.0, 1.0])), centre=_u(rng, -0.8, 0.8),
                 half_range=_u(rng, 0.8, 1.5), mix=_u(rng, -1.0, 1.0))
    elif family == "reversible":
        f.update(kind=_pick(rng, ["sigmoid", "power", "bump", "saturating"]),
                 follows=_pick(rng, ["heater", "temperature"]),
                 sign=float(rng.choice([-1.0, 1.0])), centre=_u(rng, 0.3, 0.9),
                 width=_u(rng, 0.08, 0.3), exponent=_u(rng, 2.0, 4.0), scale=_u(rng, 0.1, 0.5))
    elif family == "interaction":
        f.update(sign=1.0 if rng.random() < 0.6 else -1.0,
                 reference=_pick(rng, ["mid", "insulating", "metallic"]),
                 kernel=_pick(rng, ["linear", "stiffening"], p=[0.6, 0.4]),
                 stiffening=_u(rng, 0.0, 1.0))
    elif family == "first_point":
        f.update(relation=_pick(rng, ["along", "against", "fixed"]),
                 fixed_sign=float(rng.choice([-1.0, 1.0])),
                 directions=_pick(rng, ["symmetric", "up_only", "down_only", "asymmetric"]),
                 down_over_up=_logu(rng, 0.3, 3.0),
                 size=_pick(rng, ["constant", "linear", "sqrt", "saturating"]),
                 size_scale_V=_u(rng, 0.2, 2.0),
                 linger=int(rng.integers(0, 4)), linger_ratio=_u(rng, 0.2, 0.6))
    elif family == "backlash":
        kind = _pick(rng, ["play", "asymmetric", "multi"])
        f.update(kind=kind, up_over_down=_logu(rng, 0.3, 3.0),
                 widths=[float(x) for x in sorted(rng.uniform(0.2, 1.5, 3))],
                 weights=[float(x) for x in rng.dirichlet(np.ones(3))])
    elif family == "accommodation":
        f.update(pattern=_pick(rng, ["fatigue", "training", "narrowing", "shift", "width"]),
                 law=_pick(rng, ["saturating", "log", "power"]),
                 cycles_scale=_logu(rng, 3.0, 300.0), exponent=_u(rng, 0.3, 1.0),
                 sign=float(rng.choice([-1.0, 1.0])))
    elif family == "phase_reflectance":
        f.update(kind=_pick(rng, ["linear", "power", "percolation"]), exponent=_logu(rng, 0.4, 3.0),
                 threshold=_u(rng, 0.25, 0.6), width=_u(rng, 0.05, 0.2),
                 sign=float(rng.choice([-1.0, 1.0])), stray_centre=_u(rng, -0.5, 0.5))
    else:
        raise ValueError(f"unknown mechanism {family!r}")
    return f


# ----------------------------------------------------------------------------- drift paths


class _Path:
    """A smooth random function of run time (unit typical size), realised from a run's stream."""

    _M = 48

    def __init__(self, form: dict, rng: np.random.Generator) -> None:
        m = self._M
        # Fixed draw layout: the realisation does not depend on the form's weights.
        a = rng.standard_normal(m)
        b = rng.standard_normal(m)
        self.warm_amp = float(rng.standard_normal())
        self.trend_amp = float(rng.standard_normal())
        self.hvac_phase = float(rng.uniform(0.0, 2.0 * math.pi))
        self.hvac_amp = float(rng.uniform(0.7, 1.3)) * (1.0 if rng.random() < 0.5 else -1.0)
        self.form = form
        f = np.arange(1, m + 1) / (2.0 * _HORIZON_S)
        amp = (1.0 + (2.0 * math.pi * f * form["corr_time_s"]) ** 2) ** (-form["spectral_slope"] / 4.0)
        amp = amp / math.sqrt(float(np.sum(amp ** 2)))
        self.omega = 2.0 * math.pi * f
        self.ca, self.cb = amp * a, amp * b
        self.offset = 0.0
        if form["start"] == "zero":
            self.offset = float(self._raw(np.zeros(1))[0])

    def _raw(self, t: np.ndarray) -> np.ndarray:
        w = self.form["weights"]
        t = np.asarray(t, dtype=float)
        out = np.zeros_like(t)
        if w.get("wander", 0.0):
            ph = np.outer(t, self.omega)
            out += w["wander"] * (np.cos(ph) @ self.ca + np.sin(ph) @ self.cb)
        if w.get("warmup", 0.0):
            out += w["warmup"] * self.warm_amp * (1.0 - np.exp(-t / self.form["warmup_tau_s"]))
        if w.get("trend", 0.0):
            out += w["trend"] * self.trend_amp * t / _HORIZON_S
        if w.get("hvac", 0.0):
            ph = 2.0 * math.pi * t / self.form["hvac_period_s"] + self.hvac_phase
            shape = self.form["hvac_shape"]
            if shape == "sine":
                s = np.sin(ph)
            elif shape == "triangle":
                s = (2.0 / math.pi) * np.arcsin(np.sin(ph))
            else:
                s = 2.0 * ((ph / (2.0 * math.pi)) % 1.0) - 1.0
            out += w["hvac"] * self.hvac_amp * s
        return out

    def __call__(self, t) -> np.ndarray:
        return self._raw(np.atleast_1d(t)) - self.offset


# ----------------------------------------------------------------------------- helpers


@dataclasses.dataclass
class _Reference:
    u_lo: float
    u_hi: float
    swing: float
    half_phase: float
    slope_max: float  # max |d phase / d v| on the major loop (um/V)


def _reference(device: base.BaseDevice, need_slope: bool) -> _Reference:
    up = np.linspace(device.v_min_V, device.v_max_V, 121 if need_slope else 61)
    ramp = np.concatenate([up, up[::-1]])
    h = device.hysteresis()
    ph = np.array([h.move(v) for v in ramp])
    u = device.bias_um + device.thermal_um_per_V * ramp + ph
    slope = 0.0
    if need_slope:
        slope = float(np.max(np.abs(np.diff(ph)) / np.abs(np.diff(ramp)).clip(1e-12)))
    return _Reference(float(u.min()), float(u.max()), float(u.max() - u.min()),
                      device.phase_swing_um, max(slope, 1e-6))


def _turning_points(x0: float, xs) -> list[float]:
    out: list[float] = []
    last, d = x0, 0
    for x in xs:
        nd = (x > last) - (x < last)
        if nd == 0:
            continue
        if d != 0 and nd != d:
            out.append(last)
        d, last = nd, x
    if not out or out[-1] != last:
        out.append(last)
    return out


class _Film:
    """The film's phase part, with optional cycling-dependent weights and mean-field interaction."""

    def __init__(self, device, ref, accommodation, interaction):
        self.device, self.ref = device, ref
        self.S = ref.half_phase
        self.acc = accommodation  # (form, strength) or None
        self.inter = interaction  # (form, strength) or None
        self.cycles = 0.0
        self.mod_device = None
        if accommodation is not None:
            form, _ = accommodation
            self.mod_device = dataclasses.replace(device, density_um=device.density_um * _acc_pattern(device, form))
        self.kappa = 0.0
        if interaction is not None:
            form, s = interaction
            gain = s * _SCALE["interaction"] * form["amplitude"]
            dmax = 1.0
            if form["kernel"] == "stiffening":
                b = form["stiffening"]
                dmax = (1.0 + 3.0 * b) / (1.0 + b)
            self.kappa = form["sign"] * gain / (ref.slope_max * dmax)
        self.reset()

    def reset(self):
        self.h = self.device.hysteresis()
        self.hm = self.mod_device.hysteresis() if self.mod_device is not None else None
        self._p = self.h.value()
        self._pm = self.hm.value() if self.hm is not None else 0.0

    def weight_factor(self) -> float:
        form, s = self.acc
        n, n0 = self.cycles, form["cycles_scale"]
        if form["law"] == "saturating":
            g = (1.0 - math.exp(-n / n0)) / (1.0 - math.exp(-_ACC_CYCLES / n0))
        elif form["law"] == "log":
            g = math.log1p(n / n0) / math.log1p(_ACC_CYCLES / n0)
        else:
            g = (n / _ACC_CYCLES) ** form["exponent"]
        gain = {"fatigue": 0.6, "training": 0.6, "narrowing": 1.5}.get(form["pattern"], 3.0)
        return s * _SCALE["accommodation"] * form["amplitude"] * gain * g

    def _total(self, p_base, p_mod) -> float:
        if self.hm is None:
            return p_base
        return p_base + self.weight_factor() * p_mod

    def peek(self, x) -> float:
        return self._total(self.h.peek(x), self.hm.peek(x) if self.hm is not None else 0.0)

    def value(self) -> float:
        return self.phase()

    def _field(self, p: float) -> float:
        form, _ = self.inter
        ref = {"mid": 0.0, "insulating": self.S, "metallic": -self.S}[form["reference"]]
        q = p
        if form["kernel"] == "stiffening":
            b = form["stiffening"]
            q = p * (1.0 + b * (p / self.S) ** 2) / (1.0 + b)
        return q + ref

    def move(self, x: float) -> None:
        if self.inter is not None:
            xe = x + self.kappa * self._field(self.value())
            for _ in range(60):
                xn = x + self.kappa * self._field(self.peek(xe))
                if abs(xn - xe) < 1e-10:
                    xe = xn
                    break
                xe = 0.5 * (xe + xn) if _ > 30 else xn
            x = xe
        before = self._p
        self._p = self.h.move(x)
        if self.hm is not None:
            self._pm = self.hm.move(x)
            self.cycles += abs(self._p - before) / (2.0 * self.S) / 2.0

    def phase(self) -> float:
        """The phase part (um) after the last move."""
        if self.hm is None:
            return self._p
        return self._p + self.weight_factor() * self._pm


def _acc_pattern(device, form) -> np.ndarray:
    """The pattern ``m`` of the cycling-dependent weights: ``density (1 + a(N) m)``, ``|m| <= 1``."""
    alpha, beta = device.grid.cell_centres()
    d = device.density_um
    w = d / d.sum()
    c = 0.5 * (alpha + beta)
    width = alpha - beta
    mc = float(w @ c)
    sc = math.sqrt(max(float(w @ (c - mc) ** 2), 1e-12))
    mw = float(w @ width)
    sw = math.sqrt(max(float(w @ (width - mw) ** 2), 1e-12))
    pat = form["pattern"]
    if pat == "fatigue":
        m = -np.ones_like(c)
    elif pat == "training":
        m = np.ones_like(c)
    elif pat == "narrowing":
        m = 1.0 - np.minimum(((c - mc) / sc) ** 2, 2.0)
    elif pat == "shift":
        m = form["sign"] * np.clip((c - mc) / sc, -3.0, 3.0) / 3.0
    else:  # width
        m = form["sign"] * np.clip((width - mw) / sw, -3.0, 3.0) / 3.0
    return m


def _size(form, step: float, vmax: float) -> float:
    kind = form["size"]
    if kind == "constant":
        return 1.0
    if kind == "linear":
        return step / vmax
    if kind == "sqrt":
        return math.sqrt(step / vmax)
    return 1.0 - math.exp(-step / form["size_scale_V"])


def _sensor_shape(form, ref):
    """F(u) - u for the PSD nonlinearity, normalised to 1 at most over the output range."""
    mid, half = 0.5 * (ref.u_lo + ref.u_hi), 0.5 * ref.swing
    c = mid + form["centre"] * half
    L = form["half_range"] * half
    kind, mix = form["kind"], form["mix"]

    def g(u):
        z = (np.asarray(u, dtype=float) - c) / L
        if kind == "cubic":
            return z ** 3
        if kind == "tanh":
            return np.tanh(z) - z
        if kind == "sinh":
            return np.sinh(z) - z
        if kind == "quadratic":
            return z ** 2
        return z ** 3 + mix * z ** 2

    grid = np.linspace(ref.u_lo, ref.u_hi, 401)
    norm = max(float(np.max(np.abs(g(grid) - g(c)))), 1e-12)
    g0 = float(g(c))
    return lambda u: form["sign"] * (g(u) - g0) / norm


def _joule_shape(form, vmax):
    kind = form["kind"]

    def h(v):
        r = np.asarray(v, dtype=float) / vmax
        if kind == "power":
            hv = vmax * r ** 2
        elif kind == "exponent":
            hv = vmax * np.abs(r) ** form["exponent"]
        else:
            b = form["tcoef"]
            hv = vmax * (r ** 2 + b * r ** 4) / (1.0 + b)
        return hv - vmax * r

    grid = np.linspace(0.0, vmax, 601)
    norm = max(float(np.max(np.abs(h(grid)))), 1e-12)
    return lambda v: h(v) / norm


def _reversible_shape(form):
    kind, qc, w = form["kind"], form["centre"], form["width"]

    def r(q):
        q = np.asarray(q, dtype=float)
        if kind == "sigmoid":
            return np.tanh((q - qc) / w)
        if kind == "power":
            return np.abs(q) ** form["exponent"]
        if kind == "bump":
            return np.exp(-0.5 * ((q - qc) / w) ** 2)
        return 1.0 - np.exp(-q / form["scale"])

    grid = np.linspace(0.0, 1.0, 401)
    r0 = float(r(0.0))
    norm = max(float(np.max(np.abs(r(grid) - r0))), 1e-12)
    return lambda q: form["sign"] * (r(q) - r0) / norm


def _reflectance_shape(form):
    kind = form["kind"]

    def f(phi):
        phi = min(max(phi, 0.0), 1.0)
        if kind == "linear":
            return phi
        if kind == "power":
            return phi ** form["exponent"]
        s = lambda p: 1.0 / (1.0 + math.exp(-(p - form["threshold"]) / form["width"]))
        return (s(phi) - s(0.0)) / (s(1.0) - s(0.0))

    return f


# ----------------------------------------------------------------------------- simulation


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see ``SPEC.md``); one dict per run: ``t_s``, ``v_V``, ``y_um``, ``dwell_s``."""
    eff: dict[str, tuple[dict, float]] = {}
    for family, form, strength in effects:
        if family not in LIBRARY and family not in OUTSIDE:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if s < 0.0:
            raise ValueError("strength must be >= 0")
        if s > 0.0:
            eff[family] = (form, s)

    vmax, k = device.v_max_V, device.kelvin_per_V2
    ref = _reference(device, need_slope="interaction" in eff)
    film = _Film(device, ref, eff.get("accommodation"), eff.get("interaction"))
    thermal = "thermal_lag" in eff or "ambient_drift" in eff

    # thermal paths
    lag_w = lag_tau = lag_theta = None
    w_fast = 1.0
    if "thermal_lag" in eff:
        form, s = eff["thermal_lag"]
        lag_w = s * _SCALE["thermal_lag"] * form["amplitude"] * np.asarray(form["fractions"]) * np.asarray(form["signs"])
        lag_tau = np.asarray(form["taus_s"], dtype=float)
        lag_theta = np.zeros_like(lag_w)
        w_fast = 1.0 - float(lag_w.sum())
    # creep modes: delayed compliance, z_j relaxes towards w_j g(u) (nonlinear standard linear solid)
    if "creep" in eff:
        cform, cs = eff["creep"]
        c_tau = np.asarray(cform["taus_s"], dtype=float)
        c_w = cs * _SCALE["creep"] * cform["amplitude"] * cform["sign"] * np.asarray(cform["weights"])
        c_z = np.zeros_like(c_tau)       # delayed deflection of each mode (um)
        c_target = np.zeros_like(c_tau)  # where each mode is heading (um)
        c_time = 0.0
    # backlash state (play operators on the output)
    play_state = None
    if "backlash" in eff:
        bform, bs = eff["backlash"]
        r0 = bs * _SCALE["backlash"] * bform["amplitude"] * ref.swing
        if bform["kind"] == "play":
            plays = [(r0, r0, 1.0)]
        elif bform["kind"] == "asymmetric":
            q = bform["up_over_down"]
            plays = [(2.0 * r0 / (1.0 + q), 2.0 * r0 * q / (1.0 + q), 1.0)]
        else:
            plays = [(r0 * wd, r0 * wd, wt) for wd, wt in zip(bform["widths"], bform["weights"])]
    sensor_F = _sensor_shape(eff["sensor_nonlinearity"][0], ref) if "sensor_nonlinearity" in eff else None
    joule_h = _joule_shape(eff["joule_power"][0], vmax) if "joule_power" in eff else None
    rev_r = _reversible_shape(eff["reversible"][0]) if "reversible" in eff else None
    refl_f = _reflectance_shape(eff["phase_reflectance"][0]) if "phase_reflectance" in eff else None
    u_rest = device.output(-ref.half_phase, device.v_min_V)  # the beam at 0 V, insulating

    results = []
    session_t = 0.0   # session clock (s)

    def thermal_advance(dt: float, v: float) -> None:
        nonlocal lag_theta
        if lag_theta is not None and dt > 0.0:
            P = k * v * v
            e = np.exp(-dt / lag_tau)
            lag_theta = lag_w * P + (lag_theta - lag_w * P) * e

    def lag_rise(v: float, dt: float) -> float:
        """Film rise (K) dt after the current state with heater at v (state not advanced)."""
        P = k * v * v
        if lag_theta is None:
            return P
        e = np.exp(-dt / lag_tau)
        return w_fast * P + float(np.sum(lag_w * P + (lag_theta - lag_w * P) * e))

    def creep_load(u: float) -> float:
        """The nonlinear 'load' the delayed compliance follows: g(u - u_rest) (um), g(0) = 0."""
        d = (u - u_rest) / ref.swing
        resp = cform["response"]
        if resp == "power":
            g = math.copysign(abs(d) ** cform["exponent"], d)
        elif resp == "saturating":
            s0 = cform["saturation"]
            g = s0 * math.tanh(d / s0) / math.tanh(1.0 / s0)
        else:
            g = d
        return g * ref.swing

    def creep_advance(t: float) -> None:
        nonlocal c_time
        if t > c_time:
            q = cform["down_over_up"]
            tau = np.where(c_target < c_z, c_tau * q, c_tau)  # creeping down is q times slower
            c_z[:] = c_target + (c_z - c_target) * np.exp(-(t - c_time) / tau)
            c_time = t

    def creep_event(t: float, u_new: float) -> None:
        creep_advance(t)
        c_target[:] = c_w * creep_load(u_new)

    def play(u: float) -> float:
        nonlocal play_state
        if play_state is None:  # the mount was last dragged down (the film cooled to 0 V)
            play_state = [u + up for (lo, up, _) in plays]
        out = 0.0
        for i, (lo, up, wt) in enumerate(plays):
            play_state[i] = min(max(play_state[i], u - lo), u + up)
            out += wt * (play_state[i] - u)
        return u + out

    for run, sched in enumerate(schedules):
        v_arr = np.asarray(sched["v_V"], dtype=float)
        d_arr = np.asarray(sched["dwell_s"], dtype=float)
        K = int(sched.get("readings", 1))
        n = len(v_arr)
        trng = _stream(seed, run, "timing")
        latency = trng.uniform(0.02, 0.12, n)
        overhead = trng.uniform(0.05, 0.30, n)
        gap = _GAP_S + float(trng.uniform(-30.0, 60.0))
        burst = max(K, 1) * _SAMPLE_PERIOD_S

        if run > 0:
            # heater off between runs: the film cools (negative saturation), the beam returns to rest
            thermal_advance(gap, 0.0)  # heater already off from run end (applied below)
            session_t += gap
        run_start = session_t
        film.reset()
        paths = {}
        for fam in ("baseline_drift", "ambient_drift", "gain_drift"):
            if fam in eff:
                paths[fam] = _Path(eff[fam][0], _stream(seed, run, "path:" + fam))
        # first_point state
        fp_prev_v, fp_dir, fp_amp, fp_k = 0.0, -1, 0.0, 99
        x_now = device.v_min_V
        if thermal:
            x_now = float(device.equivalent_voltage(lag_rise(0.0, 0.0) + _amb(eff, paths, 0.0)))

        t_read = np.empty(n)
        dwell_log = np.empty(n)
        y = np.empty(n)
        t_set = 0.0  # run time of the set-point change
        for i in range(n):
            v = float(v_arr[i])
            dwell = float(d_arr[i])
            tr = t_set + dwell + latency[i] + 0.5 * burst
            # ---- temperature -> hysterons' input
            if thermal:
                fracs = (1e-3, 0.03, 0.1, 0.25, 0.5, 0.75) if lag_theta is not None else ()
                taus = [f * dwell for f in fracs] + [tr - t_set]
                xs = []
                for tau in taus:
                    rise = lag_rise(v, tau) + _amb(eff, paths, t_set + tau)
                    xs.append(float(device.equivalent_voltage(rise)))
                for xt in _turning_points(x_now, xs):
                    film.move(xt)
                x_now = xs[-1]
                # the bimorph follows the temperature: a rise deficit (K) counts at the beam's mean
                # sensitivity, thermal_um_per_V * v_max per full-scale rise k v_max^2
                v_th = v + (lag_rise(v, tr - t_set) - k * v * v) / (k * vmax) if lag_theta is not None else v
                temp_q = (lag_rise(v, tr - t_set) + _amb(eff, paths, tr)) / (k * vmax * vmax)
            else:
                film.move(v)
                v_th = v
                temp_q = (v / vmax) ** 2
            phase = film.phase()
            # ---- deflection
            u = device.output(phase, v_th)
            if joule_h is not None:
                form, s = eff["joule_power"]
                u += s * _SCALE["joule_power"] * form["amplitude"] * ref.swing \
                    * math.copysign(1.0, device.thermal_um_per_V) * float(joule_h(v_th))
            if rev_r is not None:
                form, s = eff["reversible"]
                q = v_th / vmax if form["follows"] == "heater" else temp_q
                u += s * _SCALE["reversible"] * form["amplitude"] * ref.swing * float(rev_r(q))
            # ---- mechanics
            if "creep" in eff:
                creep_event(run_start + t_set, u)
                creep_advance(run_start + tr)
                um = u + float(np.sum(c_z))
            else:
                um = u
            if "first_point" in eff:
                form, s = eff["first_point"]
                step = abs(v - fp_prev_v)
                if step > 1e-9:
                    d = 1 if v > fp_prev_v else -1
                    if d != fp_dir:
                        mult = 1.0
                        q = form["down_over_up"]
                        dirs = form["directions"]
                        if dirs == "up_only":
                            mult = 1.0 if d > 0 else 0.0
                        elif dirs == "down_only":
                            mult = 1.0 if d < 0 else 0.0
                        elif dirs == "asymmetric":
                            mult = (q if d < 0 else 1.0) / max(1.0, q)
                        rel = form["relation"]
                        sg = d if rel == "along" else (-d if rel == "against" else form["fixed_sign"])
                        fp_amp = s * _SCALE["first_point"] * form["amplitude"] * ref.swing \
                            * sg * mult * _size(form, step, vmax)
                        fp_k = 0
                    fp_dir = d
                    fp_prev_v = v
                if fp_k <= form["linger"]:
                    um += fp_amp * form["linger_ratio"] ** fp_k
                fp_k += 1
            if "backlash" in eff:
                um = play(um)
            # ---- sensor
            yy = um
            if sensor_F is not None:
                form, s = eff["sensor_nonlinearity"]
                yy = yy + s * _SCALE["sensor_nonlinearity"] * form["amplitude"] * ref.swing * float(sensor_F(yy))
            if refl_f is not None:
                form, s = eff["phase_reflectance"]
                phi = (phase + ref.half_phase) / (2.0 * ref.half_phase)
                z = 0.5 * (ref.u_lo + ref.u_hi) + form["stray_centre"] * 0.5 * ref.swing
                eps = s * _SCALE["phase_reflectance"] * form["amplitude"] * form["sign"] * refl_f(phi)
                yy = yy - eps * (yy - z)
            if "gain_drift" in eff:
                form, s = eff["gain_drift"]
                yy = yy * (1.0 + s * _SCALE["gain_drift"] * form["amplitude"] * float(paths["gain_drift"](tr)[0]))
            if "baseline_drift" in eff:
                form, s = eff["baseline_drift"]
                yy = yy + s * _SCALE["baseline_drift"] * form["amplitude"] * ref.swing \
                    * float(paths["baseline_drift"](tr)[0])
            y[i] = yy
            t_read[i] = tr
            dwell_log[i] = tr - t_set
            # ---- clock: heater held at v until the next set-point change
            t_next = tr + 0.5 * burst + overhead[i]
            thermal_advance(t_next - t_set, v)
            t_set = t_next
        # end of run: heater off
        session_t = run_start + t_set
        if "creep" in eff:
            creep_event(session_t, u_rest)
        if "backlash" in eff:
            play(u_rest)
        if noise_um is not None and noise_um > 0.0:
            y = y + _stream(seed, run, "noise").normal(0.0, float(noise_um), n)
        results.append({"t_s": t_read, "v_V": v_arr.copy(), "y_um": y, "dwell_s": dwell_log})
    return results


def _amb(eff, paths, t: float) -> float:
    """Ambient temperature excursion (K) at run time t."""
    if "ambient_drift" not in eff:
        return 0.0
    form, s = eff["ambient_drift"]
    return s * _SCALE["ambient_drift"] * form["amplitude"] * float(paths["ambient_drift"](t)[0])


__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
