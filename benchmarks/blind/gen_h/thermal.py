"""The film's temperature as a dynamical system driven by the heater's power.

The base device's beam responds in well under a second (instantaneous here).  The slow paths
(substrate, die, package, a temperature-regulated stage) are written as a *slow shape*:

    theta_film(t) = c0 * R(v(t)) + sum_i z_i(t) + z_nl(t),      tau_i dz_i/dt = w_i R(v) - z_i

with ``R(v) = kelvin_per_V2 v**2`` the steady rise and ``c0 + sum w_i + w_nl = 1`` (the steady
state is the base device's).  The linear part is kept in modal (diagonal state-space) form and
integrated exactly over each dwell; the optional nonlinear path is a one-state ODE

    tau(T, dT/dt) dT/dt = R(v) - T,        z_nl = w_nl T,

with a temperature-dependent conductance and, optionally, the latent heat of VO2 film on the
die (a heat-capacity peak at the heating or the cooling transition temperature, depending on
the direction: a rate-dependent, direction-dependent element), integrated with an exponential
midpoint rule on sub-steps.
"""

from __future__ import annotations

import math

import numpy as np

KINDS = ("parallel_rc", "ladder", "cole_cole", "regulated_stage", "nonlinear_conductance")


def _logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def draw(rng: np.random.Generator) -> dict:
    kind = KINDS[int(rng.integers(len(KINDS)))]
    f: dict = {"kind": kind}
    if kind == "parallel_rc":
        m = int(rng.integers(1, 4))
        f["taus_s"] = sorted(_logu(rng, 4.0, 900.0) for _ in range(m))
        f["weights"] = [float(w) for w in rng.dirichlet(np.ones(m))]
    elif kind == "ladder":
        n = int(rng.integers(2, 5))
        f["node_taus_s"] = sorted(_logu(rng, 4.0, 3_000.0) for _ in range(n))
        f["conductances"] = [_logu(rng, 0.2, 5.0) for _ in range(n)]
    elif kind == "cole_cole":
        f["tau_s"] = _logu(rng, 5.0, 300.0)
        f["alpha"] = float(rng.uniform(0.4, 0.9))
    elif kind == "regulated_stage":
        f["lag_tau_s"] = _logu(rng, 5.0, 120.0)
        f["lag_weight"] = float(rng.uniform(0.0, 1.0))
        f["bump"] = float(rng.uniform(0.5, 2.0))
        f["plant_tau_s"] = _logu(rng, 5.0, 60.0)
        f["controller_ratio"] = float(rng.uniform(2.0, 20.0))
    elif kind == "nonlinear_conductance":
        f["tau0_s"] = _logu(rng, 5.0, 200.0)
        f["beta"] = float(rng.uniform(-0.4, 1.0))
        f["latent_peak"] = float(rng.uniform(0.5, 4.0)) if rng.random() < 0.6 else 0.0
        f["latent_width_factor"] = float(rng.uniform(0.7, 1.5))
        f["nl_weight"] = float(rng.uniform(0.4, 1.0))
        f["lin_tau_s"] = _logu(rng, 20.0, 1_200.0)
    f["lag_K"] = float(rng.uniform(0.3, 1.0))  # deficit at s = 1 after a full step (K), see README
    return f


def slow_shape(form: dict) -> tuple[np.ndarray, np.ndarray]:
    """The linear slow modes ``(a_i, tau_i)`` of the shape (weights may be negative)."""
    kind = form["kind"]
    if kind == "parallel_rc":
        return np.array(form["weights"], float), np.array(form["taus_s"], float)
    if kind == "ladder":
        taus = np.array(form["node_taus_s"], float)
        G = np.array(form["conductances"], float)
        n = taus.size
        C = taus * G
        # node i -- G[i] -- node i+1 ... node n-1 -- G[n-1] -- ambient; power into node 0
        K = np.zeros((n, n))
        for i in range(n):
            K[i, i] += G[i]
            if i + 1 < n:
                K[i, i + 1] -= G[i]
                K[i + 1, i] -= G[i]
                K[i + 1, i + 1] += G[i]
        Cs = 1.0 / np.sqrt(C)
        M = Cs[:, None] * K * Cs[None, :]  # symmetric: C^-1/2 K C^-1/2
        lam, V = np.linalg.eigh(M)
        # H(s) = e0^T (sC + K)^-1 e0 = sum_j (Cs0 V0j)^2 / (s + lam_j)
        r = (Cs[0] * V[0, :]) ** 2
        tau = 1.0 / lam
        a = r * tau
        return a / np.sum(a), tau
    if kind == "cole_cole":
        tau_c, alpha = float(form["tau_s"]), float(form["alpha"])
        u = np.arange(-10.0, 10.0 + 1e-9, 0.25)
        h = math.sin(alpha * math.pi) / (2.0 * math.pi * (np.cosh(alpha * u) + math.cos(alpha * math.pi)))
        w = h * 0.25
        tau = tau_c * np.exp(u)
        keep = (tau >= 0.5) & (tau <= 3e4)
        # the faster part is instantaneous (folded into c0), the slower part never settles
        return w[keep], tau[keep]
    if kind == "regulated_stage":
        tp = float(form["plant_tau_s"])
        tc = tp * float(form["controller_ratio"])
        A = tc / (tc - tp)
        b = float(form["bump"])
        a = [float(form["lag_weight"]), b * A, -b * A]
        t = [float(form["lag_tau_s"]), tp, tc]
        return np.array(a), np.array(t)
    if kind == "nonlinear_conductance":
        return np.array([1.0 - float(form["nl_weight"])]), np.array([float(form["lin_tau_s"])])
    raise ValueError(kind)


def deficit_scale(form: dict) -> float:
    """max over dwells of 8-60 s of |the slow shape's deficit| after a unit step (linearised)."""
    a, tau = slow_shape(form)
    ts = np.array([8.0, 12.0, 20.0, 30.0, 45.0, 60.0])
    d = (a[None, :] * np.exp(-ts[:, None] / tau[None, :])).sum(axis=1)
    if form["kind"] == "nonlinear_conductance":
        d = d + float(form["nl_weight"]) * np.exp(-ts / float(form["tau0_s"]))
    return max(float(np.max(np.abs(d))), 1e-3)


class ThermalLag:
    """State and integration of the film's temperature rise (K above the ambient)."""

    FMAX = 0.9

    def __init__(self, form: dict, strength: float, device) -> None:
        self.device = device
        r_full = float(device.rise_K(device.v_max_V))
        f1 = float(form["lag_K"]) / (r_full * deficit_scale(form))
        self.frac = self.FMAX * (1.0 - math.exp(-strength * f1 / self.FMAX))
        a, tau = slow_shape(form)
        self.w = self.frac * a
        self.tau = tau
        self.nl = form["kind"] == "nonlinear_conductance"
        dc = float(np.sum(a))
        if self.nl:
            self.w_nl = self.frac * float(form["nl_weight"])
            dc += float(form["nl_weight"])
            self.tau0 = float(form["tau0_s"])
            self.beta = float(form["beta"])
            self.latent = float(form["latent_peak"])
            width = float(device.transition_width_C) * float(form["latent_width_factor"])
            self.lat_w = max(width, 0.5)
            self.T_heat = float(device.transition_heating_C) - float(device.ambient_C)
            self.T_cool = float(device.transition_cooling_C) - float(device.ambient_C)
            self.T_ref = 100.0
        else:
            self.w_nl = 0.0
        self.c0 = 1.0 - self.frac * dc
        self.z = np.zeros(self.tau.size)
        self.T = 0.0  # the nonlinear path's temperature rise (K)

    def _tau_nl(self, T: float, direction: float) -> float:
        g = 1.0 + self.beta * T / self.T_ref
        g = max(g, 0.3)
        tau = self.tau0 / g
        if self.latent > 0.0:
            Tc = self.T_heat if direction > 0 else self.T_cool
            tau *= 1.0 + self.latent * math.exp(-0.5 * ((T - Tc) / self.lat_w) ** 2)
        return tau

    def _nl_path(self, R: float, rel: np.ndarray) -> np.ndarray:
        out = np.empty(rel.size)
        T, t_prev = self.T, 0.0
        for k, t in enumerate(rel):
            span = t - t_prev
            while span > 1e-12:
                direction = 1.0 if R >= T else -1.0
                tau_a = self._tau_nl(T, direction)
                h = min(span, 0.3 * tau_a)
                T_half = R + (T - R) * math.exp(-0.5 * h / tau_a)
                tau_m = self._tau_nl(T_half, direction)
                T = R + (T - R) * math.exp(-h / tau_m)
                span -= h
            out[k] = T
            t_prev = t
        self.T = T
        return out

    def interval(self, R: float, rel: np.ndarray) -> np.ndarray:
        """Hold the heater at steady rise ``R`` (K) from now; film rise at times ``rel`` (s, ascending).

        The state moves to the last of ``rel`` (the end of the interval).
        """
        rel = np.asarray(rel, dtype=float)
        target = self.w * R
        dz = self.z - target
        E = np.exp(-rel[:, None] / self.tau[None, :])
        zs = target[None, :] + dz[None, :] * E
        theta = self.c0 * R + zs.sum(axis=1)
        self.z = zs[-1].copy()
        if self.nl:
            theta = theta + self.w_nl * self._nl_path(R, rel)
        return theta
