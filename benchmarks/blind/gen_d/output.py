"""Deflection-level and sensor-level mechanisms, applied to the whole session at once.

Deflection: ``creep`` (relaxation after every change), ``first_point``
(a direction-change transient), ``backlash`` (play in the lever's mount).
Sensor: ``sensor_nonlinearity`` (PSD geometry), ``psd_reflectance`` (the
film's reflectance changes the spot's intensity and, with background light,
the PSD's scale), ``gain_drift`` and ``baseline_drift``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

#: Nominal size of an effect at strength 1, as a fraction of the phase swing ``2 S``.
NOMINAL = 0.012
#: Time at which the unbounded creep kernels reach 1 (s).
CREEP_REF_S = 10_800.0


def creep_kernel(k: dict, dt: np.ndarray) -> np.ndarray:
    """Normalised creep response to a unit change, ``dt`` after it (0 at 0, about 1 after hours)."""
    dt = np.maximum(dt, 0.0)
    kind = k["kind"]
    if kind == "prony":
        out = np.zeros_like(dt)
        for tau, w in zip(k["taus_s"], k["weights"]):
            out += w * -np.expm1(-dt / tau)
        return out
    if kind == "log":
        return np.log1p(dt / k["tau0_s"]) / np.log1p(CREEP_REF_S / k["tau0_s"])
    if kind == "stretched":
        return -np.expm1(-((dt / k["tau_s"]) ** k["beta"]))
    return 1.0 - (1.0 + dt / k["tau_s"]) ** (-k["m"])


def relaxation_spectrum(k: dict) -> tuple[np.ndarray, np.ndarray]:
    """Time constants and weights of anelastic elements whose linear step response is the kernel."""
    if k["kind"] == "prony":
        return np.asarray(k["taus_s"], dtype=float), np.asarray(k["weights"], dtype=float)
    taus = np.logspace(-0.3, 5.0, 18)
    t = np.logspace(-0.5, 4.6, 160)
    basis = -np.expm1(-t[:, None] / taus[None, :])
    w, _ = nnls(basis, creep_kernel(k, t))
    keep = w > 1e-6
    return taus[keep], w[keep]


def creep(form: dict, strength: float, swing: float, a: np.ndarray, r: np.ndarray,
          nxt: np.ndarray, source: np.ndarray, source0: float) -> np.ndarray:
    """Creep (um) at every reading ``r``: anelastic elements relaxing towards the source set at ``a``.

    Each element ``z`` relaxes towards the current source ``s`` (the deflection, its phase
    part, or a mix) at a rate ``(1 +/- asymmetry) / tau``, by direction, and, for the
    stress-activated kinds, faster the farther it is from ``s`` (``e' = -e (1 + |e| / sigma) / tau``).
    The reading gains ``sign * c * sum w (z - s0)``: a step ``D`` of the source creeps by ``c D K(t)``.
    """
    taus, w = relaxation_spectrum(form["kernel"])
    c = strength * 3.0 * NOMINAL * form["gain"] * form["sign"]
    sigma = form["size_saturation"] * swing if form["size"] != "linear" else np.inf
    slower = form["size"] == "saturating"  # rate falls with the step instead of rising
    up, down = 1.0 + form["asymmetry"], 1.0 - form["asymmetry"]
    z = np.full(taus.size, float(source0))
    out = np.empty(r.size)

    def advance(z, s, dt):
        if dt <= 0.0:
            return z
        e = z - s
        rate = np.where(e < 0.0, up, down) / taus
        decay = np.exp(-dt * rate)
        if np.isinf(sigma):
            return s + e * decay
        ae = np.abs(e) / sigma
        if slower:  # e' = -e / (tau (1 + |e|/sigma)): relax the linear part, then correct (one Picard step)
            eff = 1.0 / (1.0 + ae * (1.0 + decay) / 2.0)
            return s + e * np.exp(-dt * rate * eff)
        return s + e * decay / (1.0 + ae * (1.0 - decay))

    for i in range(r.size):
        z = advance(z, source[i], r[i] - a[i])
        out[i] = c * float(w @ (z - source0))
        z = advance(z, source[i], nxt[i] - r[i])
    return out


def _size(form: dict, step: float, v_half: float) -> float:
    kind = form["size"]
    if kind == "const":
        return 1.0
    if kind == "linear":
        return step / v_half
    if kind == "sqrt":
        return float(np.sqrt(step / v_half))
    v0 = form["size_scale_V"]
    return step / (step + v0) * (v_half + v0) / v_half


def first_point(form: dict, strength: float, swing: float, v: np.ndarray, v_max: float) -> np.ndarray:
    """Offsets (um) of the readings after each change of the input's direction."""
    out = np.zeros(v.size)
    prev, direction = 0.0, -1.0  # every run starts after the heater came down to 0 V
    amp, m = 0.0, 10**9
    unit = strength * NOMINAL * swing * form["gain"]
    for i, vi in enumerate(v):
        dv = vi - prev
        prev = vi
        if abs(dv) > 1e-9:
            d = 1.0 if dv > 0 else -1.0
            if d != direction:
                direction = d
                a = form["amp_up"] if d > 0 else form["amp_down"]
                amp = unit * a * _size(form, abs(dv), v_max / 2.0)
                m = 0
        if m < form["linger_points"]:
            out[i] = amp * form["linger_ratio"] ** m
            m += 1
    return out


def backlash(form: dict, strength: float, swing: float, w: np.ndarray) -> np.ndarray:
    """The mount's position (um) behind the beam's deflection ``w`` through its play."""
    half = strength * 0.6 * NOMINAL * swing * form["gain"]
    if form["kind"] == "distributed":
        widths = half * np.linspace(1.0 - form["spread"], 1.0 + form["spread"], 7)
    else:
        widths = np.array([half])
    side = float(form["initial_side"])
    m = w[0] - side * widths
    out = np.empty(w.size)
    for i, wi in enumerate(w):
        m = np.minimum(np.maximum(m, wi - widths), wi + widths)
        out[i] = float(np.mean(m + side * widths))
    return out


def nonlinearity_scale(form: dict, swing: float, u_lo: float, u_hi: float) -> tuple[float, float]:
    """The PSD's linear centre ``c`` (um) and its length scale at strength 1 (um)."""
    mid, half = (u_lo + u_hi) / 2.0, (u_hi - u_lo) / 2.0
    c = mid + form["centre"] * half
    d = max(abs(u_hi - c), abs(u_lo - c))
    target = 1.5 * NOMINAL * swing * form["gain"]
    factor = {"tanh": 3.0, "rational": 2.0, "sinh": 6.0}.get(form["kind"])
    if factor is None:  # exp: deviation ~ d^2 / (2 L)
        return c, d * d / (2.0 * target)
    return c, float(np.sqrt(d**3 / (factor * target)))


def sensor_nonlinearity(form: dict, strength: float, centre: float, length1: float, u: np.ndarray) -> np.ndarray:
    d = u - centre
    kind = form["kind"]
    if kind == "exp":
        length = form["sign"] * length1 / strength
        return centre + length * np.expm1(d / length)
    length = length1 / np.sqrt(strength)
    if kind == "tanh":
        g = length * np.tanh(d / length)
    elif kind == "rational":
        g = d / np.sqrt(1.0 + (d / length) ** 2)
    else:
        g = length * np.sinh(d / length)
    return centre + g


def psd_reflectance(form: dict, strength: float, swing: float, u_absmax: float,
                    fraction: np.ndarray) -> np.ndarray:
    """The PSD's scale factor given the film's metallic fraction (1 in the insulating state)."""
    c = form["contrast"]
    b = strength * 2.0 * NOMINAL * swing * form["gain"] / (abs(c) * u_absmax)
    refl = 1.0 + c * np.clip(fraction, 0.0, 1.0) ** form["fraction_power"]
    return (1.0 + b) * refl / (refl + b)
