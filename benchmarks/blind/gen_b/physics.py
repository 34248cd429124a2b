"""Physical building blocks of generator B: thermal networks, random drift paths, PSD responses, kernels.

Everything here is written from the physics of the rig (a Joule-heated VO2 bimorph read by an
optical lever on a position-sensitive detector), not from the model under test.
Units: V, K, um, s.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from scipy.optimize import nnls
from scipy.signal import lfilter
from scipy.special import erf, ndtr

# ----------------------------------------------------------------------------- random streams

_ROOT = 61_803_398


def stream(seed: int, *keys: str | int) -> np.random.Generator:
    """An independent random stream for ``seed`` and a tuple of keys (names hashed, ints as is)."""
    words = [_ROOT, int(seed) & 0xFFFFFFFF]
    for k in keys:
        words.append(zlib.crc32(k.encode()) if isinstance(k, str) else int(k) & 0xFFFFFFFF)
    return np.random.default_rng(np.random.SeedSequence(words))


# ----------------------------------------------------------------------------- thermal network

def foster_from_cauer(r_frac: list[float], tau_node_s: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Modes of a Cauer RC chain (anchor -> chip -> package -> ambient) seen from the beam's root.

    Node ``i`` has the thermal resistance ``r_frac[i]`` towards the next node (the last one towards the
    ambient) and the heat capacity ``tau_node_s[i] / r_frac[i]``.  The driving-point impedance is the
    Foster sum ``sum_k R_k / (1 + s tau_k)``; returns ``(tau_k, R_k / sum R_k)``.
    """
    r = np.asarray(r_frac, dtype=float)
    c = np.asarray(tau_node_s, dtype=float) / r
    g = 1.0 / r
    n = len(r)
    G = np.zeros((n, n))
    for i in range(n):
        G[i, i] += g[i]
        if i + 1 < n:
            G[i, i + 1] -= g[i]
            G[i + 1, i] -= g[i]
            G[i + 1, i + 1] += g[i]
    ci = 1.0 / np.sqrt(c)
    S = ci[:, None] * G * ci[None, :]
    lam, Q = np.linalg.eigh(S)
    R_k = Q[0, :] ** 2 / (c[0] * lam)
    tau_k = 1.0 / lam
    order = np.argsort(tau_k)
    w = R_k[order] / np.sum(R_k)
    return tau_k[order], w


class ThermalLag:
    """Film temperature rise behind a Foster network driven by the heater power.

    ``theta_f = rho0 * R P + sum_k w_k z_k``, ``tau_k dz_k/dt = R P - z_k`` with ``rho0 = 1 - sum w``,
    ``R P`` the steady rise.  The heater power may feel the heater's temperature (TCR, voltage drive
    through a source resistance): ``R P = theta_ss (1 + gamma (theta_f - theta_ss))``, linearised around the
    set-point's steady state, so that the steady state is exactly ``theta_ss`` (the base device's rise).
    """

    def __init__(self, tau_s: np.ndarray, w: np.ndarray, gamma_per_K: float) -> None:
        self.tau = np.asarray(tau_s, dtype=float)
        self.w = np.asarray(w, dtype=float)
        self.rho0 = 1.0 - float(np.sum(self.w))
        self.gamma = float(gamma_per_K)
        self.z = np.zeros(len(self.tau))

    def _system(self, theta_ss: float) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, float]:
        g, q = self.gamma, theta_ss
        den = 1.0 - self.rho0 * g * q
        # theta_f = a0 + a . z
        a0 = self.rho0 * q * (1.0 - g * q) / den
        a = self.w / den
        # dz/dt = (q (1 - g q) + g q theta_f - z) / tau = M z + b
        M = (np.outer(np.full(len(self.tau), g * q), a) - np.eye(len(self.tau))) / self.tau[:, None]
        b = (q * (1.0 - g * q) + g * q * a0) / self.tau
        return M, b, a0, a, den

    def advance(self, theta_ss: float, times: np.ndarray) -> np.ndarray:
        """Film rise at ``times`` (s from now, ascending, >= 0) holding ``theta_ss``; state moves to ``times[-1]``."""
        times = np.asarray(times, dtype=float)
        M, b, a0, a, _ = self._system(theta_ss)
        if self.gamma == 0.0:
            zs = theta_ss
            Z = zs + (self.z[None, :] - zs) * np.exp(-times[:, None] / self.tau[None, :])
        else:
            zs = -np.linalg.solve(M, b)
            lam, V = np.linalg.eig(M)
            if np.max(np.abs(lam.imag)) > 1e-12 * np.max(np.abs(lam.real)):
                from scipy.linalg import expm
                Z = np.array([zs + expm(M * t) @ (self.z - zs) for t in times])
            else:
                lam, V = lam.real, V.real
                c = np.linalg.solve(V, self.z - zs)
                Z = zs + (np.exp(np.outer(times, lam)) * c[None, :]) @ V.T
        self.z = Z[-1].copy()
        return a0 + Z @ a


# ----------------------------------------------------------------------------- random paths

def _ou(n: int, dt: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    a = math.exp(-dt / tau)
    xi = rng.standard_normal(n)
    x0 = xi[0]  # stationary start
    rest = lfilter([math.sqrt(1.0 - a * a)], [1.0, -a], xi[1:], zi=[a * x0])[0]
    return np.concatenate([[x0], rest])


def drift_path(components: list[dict], t_end: float, rng_seed: tuple) -> tuple[np.ndarray, np.ndarray]:
    """A unit-scale random path (sum of weighted components, each ~unit rms) on a 5 s grid over ``[0, t_end]``.

    Returns ``(grid_s, values)``; read it with ``np.interp``.

    ``rng_seed`` keys the run's stream: each component draws from its own sub-stream, so that a path never
    depends on anything but the seed, the run and the run's length.
    """
    dt = 5.0
    grid = np.arange(0.0, t_end + 2 * dt, dt)
    n = len(grid)
    total = np.zeros(n)
    for ci, comp in enumerate(components):
        rng = stream(*rng_seed, ci)
        kind = comp["kind"]
        if kind == "ou":
            p = _ou(n, dt, comp["tau_s"], rng)
        elif kind == "flicker":
            taus = np.geomspace(comp["tau_min_s"], comp["tau_max_s"], comp["poles"])
            p = sum(_ou(n, dt, tau, rng) for tau in taus) / math.sqrt(len(taus))
        elif kind == "warmup":
            amp = rng.uniform(0.6, 1.6)
            sgn = comp["sign"] if comp["sign"] != 0 else (1.0 if rng.random() < 0.5 else -1.0)
            p = sgn * amp * 2.0 * np.exp(-grid / comp["tau_s"])
        elif kind == "ramp":
            slope = rng.standard_normal()
            p = slope * math.sqrt(12.0) * (grid / max(t_end, 1.0) - 0.5)
        elif kind == "cycle":
            period = comp["period_s"] * rng.uniform(0.9, 1.1)
            ph = (grid / period + rng.random()) % 1.0
            duty = comp["duty"]
            tri = np.where(ph < duty, ph / duty, (1.0 - ph) / (1.0 - duty))  # heater on: rise; off: fall
            p = math.sqrt(12.0) * (tri - 0.5)
        elif kind == "steps":
            rate = 1.0 / comp["mean_interval_s"]
            k = rng.poisson(rate * grid[-1])
            when = rng.uniform(0.0, grid[-1], k)
            size = rng.standard_normal(k)
            p = np.zeros(n)
            for tw, sz in zip(when, size):
                p[grid >= tw] += sz
        else:
            raise ValueError(f"unknown drift component {kind!r}")
        total += comp["weight"] * p
    return grid, total


# ----------------------------------------------------------------------------- PSD responses

def psd_response(form: dict, d: np.ndarray) -> np.ndarray:
    """Raw normalised position signal of the detector for a spot centred at ``d`` (detector units)."""
    kind = form["detector"]
    if kind == "split_gaussian":          # bi-cell / quadrant, Gaussian spot of 1/e^2 radius 1
        return erf(math.sqrt(2.0) * d)
    if kind == "quadrant_tophat":         # bi-cell, uniform disc of radius 1
        r = np.clip(d, -1.0, 1.0)
        return (2.0 / math.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))
    if kind == "lepsd_edge":              # lateral-effect PSD [-1, 1]: centroid of the light on the active area
        s = form["sigma"]
        a, b = (-1.0 - d) / s, (1.0 - d) / s
        phi = lambda x: np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)  # noqa: E731
        mass = np.maximum(ndtr(b) - ndtr(a), 1e-300)
        return d + s * (phi(a) - phi(b)) / mass
    if kind == "tetralateral":            # pincushion of a tetra-lateral PSD, spot at height y0
        k, y0 = form["kappa"], form["y0"]
        return d * (1.0 + k * y0 * y0) / (1.0 + k * (d * d + y0 * y0))
    raise ValueError(f"unknown detector {kind!r}")


def sensor_residual(form: dict, u_lo: float, u_hi: float):
    """``r(u)``: the calibrated PSD's error (a least-squares linear calibration over the range), max |r| = 1."""
    u_mid, u_span = 0.5 * (u_lo + u_hi), max(u_hi - u_lo, 1e-9)

    def raw(u):
        return psd_response(form, form["offset"] + form["span"] * (np.asarray(u, float) - u_mid) / u_span)

    uu = np.linspace(u_lo, u_hi, 401)
    A = np.column_stack([np.ones_like(uu), raw(uu)])
    coef = np.linalg.lstsq(A, uu, rcond=None)[0]
    res = A @ coef - uu
    scale = float(np.max(np.abs(res)))
    scale = scale if scale > 0 else 1.0

    def r(u):
        u = np.asarray(u, float)
        return (coef[0] + coef[1] * raw(u) - u) / scale

    return r


# ----------------------------------------------------------------------------- creep kernels

def creep_kernel(form: dict, t: np.ndarray) -> np.ndarray:
    """Normalised creep function ``J(t)`` (0 at t <= 0; bounded kernels -> 1, unbounded ones 1 at one hour)."""
    t = np.maximum(np.asarray(t, float), 0.0)
    k = form["kernel"]
    if k == "prony":                      # generalised Kelvin-Voigt chain
        out = np.zeros_like(t)
        for tau, w in zip(form["tau_s"], form["weights"]):
            out += w * -np.expm1(-t / tau)
        return out
    if k == "kww":                        # stretched exponential (Kohlrausch)
        return -np.expm1(-np.power(t / form["tau_s"], form["beta"]))
    if k == "fractional":                 # Cole-Cole type power-law relaxation (fractional Kelvin-Voigt)
        x = np.power(t / form["tau_s"], form["alpha"])
        return x / (1.0 + x)
    if k == "log":                        # logarithmic creep (thermally activated, broad spectrum)
        return np.log1p(t / form["t0_s"]) / math.log1p(3600.0 / form["t0_s"])
    if k == "andrade":                    # Andrade / Nutting power law
        return np.power(t / 3600.0, form["alpha"])
    raise ValueError(f"unknown creep kernel {k!r}")


def creep_spectrum(form: dict) -> tuple[np.ndarray, np.ndarray]:
    """A discrete relaxation spectrum (Kelvin-Voigt units) reproducing ``creep_kernel`` over 1 s .. 6 h.

    Prony kernels are their own spectrum; the others are fitted by non-negative least squares on 31
    log-spaced time constants (0.3 s .. 3e5 s).  Returns ``(tau_s, weights)`` (``sum(weights)`` is the
    kernel's value at long times, 1 for the bounded kernels).
    """
    if form["kernel"] == "prony":
        tau, w = np.asarray(form["tau_s"], float), np.asarray(form["weights"], float)
    else:
        tau = np.geomspace(0.3, 3.0e5, 31)
        t = np.geomspace(1.0, 2.2e4, 200)
        A = -np.expm1(-t[:, None] / tau[None, :])
        # a light ridge keeps the spectrum smooth and the solver well conditioned
        A = np.vstack([A, 1e-3 * np.eye(len(tau))])
        b = np.concatenate([creep_kernel(form, t), np.zeros(len(tau))])
        w, _ = nnls(A, b, maxiter=50 * len(tau))
        keep = w > 1e-6 * w.max()
        tau, w = tau[keep], w[keep]
    return tau, w


class CreepUnits:
    """Kelvin-Voigt units ``y_k`` relaxing towards the driver ``e`` (normalised by the strength).

    Each unit follows an Eyring (stress-activated) law, ``dx/dt = -sinh(kappa x) / (kappa tau)`` with
    ``x = y - e``; solved exactly: ``x(t) = (2/kappa) artanh(tanh(kappa x0 / 2) exp(-t / tau))``.
    Loading and unloading may run at different rates (``tau (1 -+ asym)``).  The equilibrium is single
    valued (``y = e``), so nothing ratchets.
    """

    def __init__(self, tau_s: np.ndarray, weights: np.ndarray, kappa: float, asym: float) -> None:
        self.tau = np.asarray(tau_s, float)
        self.w = np.asarray(weights, float)
        self.kappa = float(kappa)
        self.asym = float(asym)
        self.y = np.zeros(len(self.tau))

    def advance(self, e: float, dt: float) -> None:
        x = self.y - e
        tau = self.tau * (1.0 + self.asym * np.sign(x))   # x < 0: creeping up (loading)
        decay = np.exp(-dt / tau)
        if self.kappa > 0:
            k = self.kappa
            x = (2.0 / k) * np.arctanh(np.tanh(0.5 * k * x) * decay)
        else:
            x = x * decay
        self.y = e + x

    def value(self) -> float:
        return float(self.w @ self.y)
