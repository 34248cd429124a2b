"""Lumped thermal network of the heater, the beam, the chip, the package and the holder.

Nodes (temperature rises above ambient, K):

* the **beam** (carrying heater and film): its own time constant is well under a second, so it is
  algebraic: ``theta_b = theta_1 + R_b * P``;
* ``N`` slow nodes in a chain (chip -> package -> holder, or the ``N`` segments of a diffusive substrate
  slab): ``C_i dtheta_i/dt = F_{i-1} - F_i`` with ``F_0 = P``, ``F_i = (theta_i - theta_{i+1}) / R_i`` and the
  last node losing heat to the room by conduction + natural convection (``~ theta^1.25``) + radiation
  (``(T_a + theta)^4 - T_a^4``).

The heater is a metal film with a temperature coefficient ``alpha`` driven through a series resistor
``R_ext = rho R_h0``: ``P = D(v) * phi(theta_b)`` with ``phi(theta) = (1 + alpha theta)(1 + rho)^2 / (1 + rho +
alpha theta)^2`` (negative electro-thermal feedback when ``rho < 1`` and ``alpha > 0``: overshoot; positive
when ``rho > 1``).  Resistances are in units of the total (``R_b + sum R_i = 1`` in the linear limit), so
``P`` is in kelvin.  ``D(v)`` is solved so that the **steady state is exactly** the base device's
``rise_K(v)``: the mechanism is purely dynamic.

Integration between set-points: exponential time differencing (ETDRK2, Cox & Matthews) around the
network's linear part, whose modes are computed once (``C^-1/2 G C^-1/2`` is symmetric): exact for the
linear network, second order in the weak nonlinearities (heater TCR, convection, radiation).
"""

from __future__ import annotations

import numpy as np


def _phi1(z: np.ndarray) -> np.ndarray:
    out = np.empty_like(z)
    small = np.abs(z) < 1e-6
    out[small] = 1.0 + z[small] / 2.0 + z[small] ** 2 / 6.0
    zz = z[~small]
    out[~small] = np.expm1(zz) / zz
    return out


def _phi2(z: np.ndarray) -> np.ndarray:
    out = np.empty_like(z)
    small = np.abs(z) < 1e-4
    out[small] = 0.5 + z[small] / 6.0 + z[small] ** 2 / 24.0
    zz = z[~small]
    out[~small] = (np.expm1(zz) - zz) / zz**2
    return out


class ThermalNetwork:
    """One device's slow thermal paths (``form``: a ``thermal_lag`` form; ``fraction``: slow share of R)."""

    def __init__(self, kelvin_per_V2: float, ambient_C: float, form: dict, fraction: float) -> None:
        self.k = float(kelvin_per_V2)
        tau = np.asarray(form["node_tau_s"], dtype=float)
        share = np.asarray(form["resistance_share"], dtype=float)
        share = share / share.sum()
        self.n = tau.size
        self.fraction = float(fraction)
        self.R_b = 1.0 - self.fraction
        self.R = self.fraction * share                    # R_1..R_N (R_N: to the room)
        self.C = tau / self.R
        self.alpha = float(form.get("tcr_per_K", 0.0))
        self.rho = float(form.get("series_ratio", 1.0))
        self.wc = float(form.get("convective_weight", 0.0))
        self.wr = float(form.get("radiative_weight", 0.0))
        self.Ta = float(ambient_C) + 273.15
        self.theta_ref = 10.0
        # linear part: C dtheta/dt = -G theta (+ P e_1 + nonlinear remainder)
        G = np.zeros((self.n, self.n))
        for i in range(self.n - 1):
            g = 1.0 / self.R[i]
            G[i, i] += g
            G[i + 1, i + 1] += g
            G[i, i + 1] -= g
            G[i + 1, i] -= g
        G[-1, -1] += self._q_slope0() / self.R[-1]
        self.G = G
        m = np.sqrt(self.C)
        mu, U = np.linalg.eigh(G / np.outer(m, m))
        self.mu = mu                                      # modal rates (1/s), all > 0
        self._to_modal = U.T * m[None, :]                # y = U^T M theta
        self._from_modal = U / m[:, None]                # theta = M^-1 U y
        self.theta = np.zeros(self.n)
        self._drive_cache: dict[float, float] = {}
        self._coef_cache: dict[float, tuple] = {}

    # ------------------------------------------------------------------ constitutive laws
    def _q_slope0(self) -> float:
        return 1.0 - self.wc

    def q(self, th):
        """Heat flow (times R_N) from the last node to the room at its rise ``th`` (K)."""
        th = np.maximum(th, 0.0)
        lin = (1.0 - self.wc - self.wr) * th
        conv = self.wc * self.theta_ref * (th / self.theta_ref) ** 1.25
        rad = self.wr * ((self.Ta + th) ** 4 - self.Ta**4) / (4.0 * self.Ta**3)
        return lin + conv + rad

    def phi(self, th):
        a, r = self.alpha, self.rho
        return (1.0 + a * th) * (1.0 + r) ** 2 / (1.0 + r + a * th) ** 2

    def dphi(self, th):
        a, r = self.alpha, self.rho
        den = 1.0 + r + a * th
        return (1.0 + r) ** 2 * (a * den - 2.0 * a * (1.0 + a * th)) / den**3

    def _q_scalar(self, th: float) -> float:
        th = th if th > 0.0 else 0.0
        Ta = self.Ta
        return ((1.0 - self.wc - self.wr) * th + self.wc * self.theta_ref * (th / self.theta_ref) ** 1.25
                + self.wr * ((Ta + th) ** 4 - Ta**4) / (4.0 * Ta**3))

    # ------------------------------------------------------------------ steady state and drive
    def _q_inverse(self, flow: np.ndarray) -> np.ndarray:
        th = np.array(flow, dtype=float)
        for _ in range(30):
            f = self.q(th) - flow
            d = (1.0 - self.wc - self.wr) + self.wc * 1.25 * (np.maximum(th, 1e-12) / self.theta_ref) ** 0.25 \
                + self.wr * (self.Ta + th) ** 3 / self.Ta**3
            step = f / d
            th = np.maximum(th - step, 0.0)
            if np.all(np.abs(step) < 1e-13 * (1.0 + np.abs(th))):
                break
        return th

    def steady_rise(self, power: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Beam rise and slow-node rises at steady state for heater power ``power`` (K units)."""
        power = np.asarray(power, dtype=float)
        thN = self._q_inverse(power * self.R[-1])
        nodes = [thN]
        for i in range(self.n - 2, -1, -1):
            nodes.append(nodes[-1] + power * self.R[i])
        nodes = nodes[::-1]
        return nodes[0] + self.R_b * power, np.array(nodes)

    def prepare(self, volts: np.ndarray) -> None:
        """Solve ``D(v)`` for many set-points at once (vectorised Newton on the steady heater power)."""
        vs = np.unique(np.asarray(volts, dtype=float))
        vs = vs[[float(x) not in self._drive_cache for x in vs]]
        if vs.size == 0:
            return
        target = self.k * vs * vs
        P = target.copy()
        rs = float(np.sum(self.R[:-1]))
        for _ in range(60):
            rise, nodes = self.steady_rise(P)
            thN = nodes[-1]
            dq = (1.0 - self.wc - self.wr) + self.wc * 1.25 * (np.maximum(thN, 1e-12) / self.theta_ref) ** 0.25 \
                + self.wr * (self.Ta + thN) ** 3 / self.Ta**3
            d = self.R_b + rs + self.R[-1] / dq
            step = (rise - target) / d
            P = P - step
            if np.all(np.abs(step) <= 1e-14 * (1.0 + np.abs(P))):
                break
        D = P / self.phi(target)
        for x, dx in zip(vs.tolist(), D.tolist()):
            self._drive_cache[x] = dx

    def drive(self, v: float) -> float:
        """``D(v)``: chosen so the steady-state beam rise is the base device's ``k v^2``."""
        key = float(v)
        if key not in self._drive_cache:
            self.prepare(np.array([key]))
        return self._drive_cache[key]

    # ------------------------------------------------------------------ dynamics
    def beam(self, theta1: float, D: float) -> tuple[float, float]:
        """Beam rise and heater power given the chip node ``theta1`` and the drive ``D`` (scalar Newton)."""
        if D == 0.0:
            return theta1, 0.0
        a, r, RbD = self.alpha, self.rho, self.R_b * D
        c = (1.0 + r) ** 2
        tb = theta1 + RbD * (1.0 + a * theta1) * c / (1.0 + r + a * theta1) ** 2
        for _ in range(20):
            den = 1.0 + r + a * tb
            ph = (1.0 + a * tb) * c / (den * den)
            dph = c * (a * den - 2.0 * a * (1.0 + a * tb)) / (den * den * den)
            step = (tb - theta1 - RbD * ph) / (1.0 - RbD * dph)
            tb -= step
            if abs(step) < 1e-13 * (1.0 + abs(tb)):
                break
        den = 1.0 + r + a * tb
        return tb, D * (1.0 + a * tb) * c / (den * den)

    def _remainder(self, theta: np.ndarray, D: float) -> np.ndarray:
        """``C^-1 (forcing + nonlinear part)``: the full right-hand side minus the linear part."""
        _, P = self.beam(float(theta[0]), D)
        r = np.zeros(self.n)
        r[0] += P
        if self.wc or self.wr:
            thN = float(theta[-1])
            r[-1] -= (self._q_scalar(thN) - self._q_slope0() * thN) / self.R[-1]
        return r / self.C

    def _coefficients(self, h: float):
        c = self._coef_cache.get(h)
        if c is None:
            z = -self.mu * h
            c = (np.exp(z), _phi1(z) * h, _phi2(z) * h)
            if len(self._coef_cache) < 4096:
                self._coef_cache[h] = c
        return c

    def advance(self, D: float, h: float) -> None:
        """Advance the slow nodes by ``h`` seconds at constant drive ``D`` (ETDRK2)."""
        if h <= 0.0:
            return
        e, p1, p2 = self._coefficients(float(h))
        y = self._to_modal @ self.theta
        n0 = self._to_modal @ self._remainder(self.theta, D)
        a = e * y + p1 * n0
        na = self._to_modal @ self._remainder(self._from_modal @ a, D)
        self.theta = self._from_modal @ (a + p2 * (na - n0))

    def trajectory(self, D: float, times: np.ndarray) -> np.ndarray:
        """Advance through increasing ``times`` (s from now) and return the beam rise at each."""
        out = np.empty(len(times))
        t0 = 0.0
        for j, t in enumerate(times):
            self.advance(D, float(t) - t0)
            t0 = float(t)
            out[j] = self.beam(float(self.theta[0]), D)[0]
        return out
