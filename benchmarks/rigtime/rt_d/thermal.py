"""The cantilever's thermal network and its exact (modal) solution over one set-point.

The beam is a 1-D heat conductor discretised into ``cells`` finite volumes along
its length ``s`` in ``[0, 1]`` (root at 0, free tip at 1).  Node order is a
chain: ``[package, cell 0, ..., cell N-1]`` (the package node only exists when
the form has one), so the conductance matrix is tridiagonal and the generalised
eigenproblem ``G phi = lambda C phi`` is solved with ``eigh_tridiagonal``.

State: the temperature rise of every node in *normalised* units ``theta = rise / kelvin_per_V2``
(V^2), so that the steady state at heater voltage ``v`` is ``theta_ss = v^2 * gamma`` and the
film patches' share-weighted mean of ``gamma`` is 1.  Each output ``o`` (the film patches,
then the beam's thermal-bending average) has its own DC gain ``g_o``; its equivalent voltage
is ``sqrt(theta_o / g_o)``, exactly ``v`` at steady state.

Within one set-point the capacities are frozen (see ``capacities``) and the heater voltage
relaxes to the set-point through the driver (first order, rise and fall time constants), so
the power is ``v_h(t)^2 = v^2 + 2 v d e^{-mu t} + d^2 e^{-2 mu t}`` and the node
temperatures are a closed-form sum of exponentials.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh_tridiagonal


class Network:
    """The linear thermal network a form describes (built deterministically from it)."""

    def __init__(self, form: dict) -> None:
        N = int(form["cells"])
        pkg = form.get("package")
        off = 1 if pkg else 0
        n = N + off
        self.N, self.off, self.n = N, off, n
        edges = (np.arange(N + 1) / N)
        centres = (np.arange(N) + 0.5) / N

        def cover(a: float, b: float) -> np.ndarray:
            """Fraction of each cell covered by the interval [a, b]."""
            lo = np.maximum(edges[:-1], a)
            hi = np.minimum(edges[1:], b)
            return np.clip(hi - lo, 0.0, None) * N

        scale = float(form["time_scale"])
        h0, h1 = form["heater"]
        heater = cover(h0, h1)
        cap = (1.0 + float(form["heater_cap_extra"]) * heater) / N
        loss = np.full(N, float(form["loss_G"]) / N)
        cap[-1] += float(form["paddle_cap"])
        loss[-1] += float(form["paddle_loss_G"])
        # conductances: chain links and ground
        link = np.full(n - 1, float(N))  # cell-to-cell: conductance N (beam end-to-end = 1)
        ground = np.zeros(n)
        ground[off:] = loss
        anchor = 1.0 / (1.0 / float(form["anchor_G"]) + 1.0 / (2.0 * N))
        C = np.zeros(n)
        C[off:] = cap * scale
        self.cp_mask = np.zeros(n)
        self.cp_mask[off:] = 1.0
        if pkg:
            link[0] = anchor
            ground[0] = 1.0 / float(pkg["R"])
            C[0] = float(pkg["C"]) * scale
        else:
            ground[off] += anchor
        self.C0 = C
        # tridiagonal G
        diag = ground.copy()
        diag[:-1] += link
        diag[1:] += link
        self.g_diag = diag
        self.g_off = -link
        b = np.zeros(n)
        b[off:] = heater / max(heater.sum(), 1e-300)
        # outputs: film patches (length-averaged temperature), then thermal bending
        f0, f1 = form["film"]
        M = int(form["patches"])
        bounds = f0 + (f1 - f0) * np.arange(M + 1) / M
        H = np.zeros((M + 1, n))
        cov = np.zeros((M, n))
        share = np.zeros(M)
        for i in range(M):
            c = cover(bounds[i], bounds[i + 1])
            cov[i, off:] = c
            H[i, off:] = c / c.sum()
            a, bb = bounds[i], bounds[i + 1]
            share[i] = (bb - a) - 0.5 * (bb * bb - a * a)  # integral of (1 - s) ds: moment arm to the tip
        share /= share.sum()
        th = (1.0 - centres)
        H[M, off:] = th / th.sum()
        self.M = M
        self.H = H
        self.share = share
        self.film_cov = cov  # (M, n) fraction of each node's capacity covered by each patch
        gamma = self._solve_ss(b)
        film_gain = float(share @ (H[:M] @ gamma))
        self.b = b / film_gain
        self.gamma = gamma / film_gain  # theta_ss per V^2
        self.gain = H @ self.gamma  # (M+1,) DC gains of the outputs
        self.cp_per_K = float(form["cp_per_K"])
        self.latent_K = float(form["latent_K"])
        self.latent_cap = float(form["latent_K"]) * float(form["latent_slope_cap_per_K"])
        drv = form.get("driver")
        self.tau_up = float(drv["tau_up_s"]) if drv else 0.0
        self.tau_down = float(drv["tau_down_s"]) if drv else 0.0

    def _solve_ss(self, b: np.ndarray) -> np.ndarray:
        from scipy.linalg import solve_banded
        ab = np.zeros((3, self.n))
        ab[0, 1:] = self.g_off
        ab[1] = self.g_diag
        ab[2, :-1] = self.g_off
        return solve_banded((1, 1), ab, b)

    # ------------------------------------------------------------------ capacities
    def capacities(self, T_dest_K: np.ndarray, latent_factor: np.ndarray) -> np.ndarray:
        """Frozen capacities for one set-point.

        ``T_dest_K`` (n,) the destination rise of each node (K): silicon's specific heat grows
        with temperature, linearised at the destination (which governs the settling);
        ``latent_factor`` (M,) the secant extra capacity of each film patch from the latent heat
        of the grains that switch on this step, in units of the covered cells' capacity.
        """
        C = self.C0 * (1.0 + self.cp_per_K * self.cp_mask * np.maximum(T_dest_K, 0.0))
        if latent_factor is not None and np.any(latent_factor > 0):
            C = C + self.C0 * (latent_factor @ self.film_cov)
        return C

    def modes(self, C: np.ndarray):
        """``(lam, U, Cs)``: ``G phi = lam C phi`` with ``phi = U / Cs``."""
        Cs = np.sqrt(C)
        d = self.g_diag / C
        e = self.g_off / (Cs[:-1] * Cs[1:])
        lam, U = eigh_tridiagonal(d, e)
        return lam, U, Cs

    def step_weights(self, C: np.ndarray, output: np.ndarray):
        """Time constants (s) and weights of the modes in the step response of ``output . theta``."""
        lam, U, Cs = self.modes(C)
        Ho = (output / Cs) @ U
        Bv = U.T @ (self.b / Cs)
        r = Ho * Bv / lam
        return 1.0 / lam, r / r.sum()


class Segment:
    """The closed-form trajectory over one set-point (time from the set-point change)."""

    def __init__(self, net: Network, C: np.ndarray, theta0: np.ndarray, vh0: float, v: float,
                 modes=None) -> None:
        self.net = net
        lam, U, Cs = modes if modes is not None else net.modes(C)
        self.lam, self.U, self.Cs = lam, U, Cs
        self.v = v
        self.theta_ss = v * v * net.gamma
        self.out_ss = v * v * net.gain
        self.z0 = U.T @ (Cs * (theta0 - self.theta_ss))
        self.Bv = U.T @ (net.b / Cs)
        self.Ho = (net.H / Cs) @ U  # (M+1, n)
        d = vh0 - v
        tau = net.tau_up if v > vh0 else net.tau_down
        self.vh0 = vh0
        if tau > 0.0 and d != 0.0:
            mu = 1.0 / tau
            # keep the driver's rates off the thermal ones (a 0.2 % nudge at most), so that the
            # closed form below stays well conditioned
            for _ in range(4):
                near = (np.abs(lam - mu) < 1e-3 * mu) | (np.abs(lam - 2.0 * mu) < 2e-3 * mu)
                if not np.any(near):
                    break
                mu *= 1.0 + 2e-3
            self.mu = np.array([mu, 2.0 * mu])
            self.rho = np.array([2.0 * v * d, d * d])
        else:
            self.mu = np.zeros(0)
            self.rho = np.zeros(0)
        # z(t) = e^{-lam t} a + sum_m e^{-mu_m t} c_m  (the driver's transient drives the modes)
        self.c = np.array([self.rho[m] * self.Bv / (lam - self.mu[m]) for m in range(self.mu.size)])
        self.a = self.z0 - (self.c.sum(axis=0) if self.mu.size else 0.0)
        self.Ao = self.Ho * self.a  # (M+1, n)
        self.Co = self.c @ self.Ho.T if self.mu.size else np.zeros((0, self.Ho.shape[0]))

    def z(self, t: np.ndarray) -> np.ndarray:
        """Modal coordinates (T, n)."""
        tt = np.asarray(t, dtype=float)[:, None]
        Z = np.exp(-self.lam * tt) * self.a
        if self.mu.size:
            Z = Z + np.exp(-tt * self.mu) @ self.c
        return Z

    def dev(self, t: np.ndarray) -> np.ndarray:
        """Outputs' deviation from their steady state, ``theta_o(t) - v^2 g_o``, (T, M+1)."""
        tt = np.asarray(t, dtype=float)[:, None]
        D = np.exp(-self.lam * tt) @ self.Ao.T
        if self.mu.size:
            D = D + np.exp(-tt * self.mu) @ self.Co
        return D

    def ddev(self, t: np.ndarray) -> np.ndarray:
        """Time derivative of ``dev`` (T, M+1)."""
        tt = np.asarray(t, dtype=float)[:, None]
        D = -(np.exp(-self.lam * tt) * self.lam) @ self.Ao.T
        if self.mu.size:
            D = D - (np.exp(-tt * self.mu) * self.mu) @ self.Co
        return D

    def theta(self, t: float) -> np.ndarray:
        """All node temperatures at ``t`` (n,)."""
        return self.theta_ss + (self.U @ self.z(np.array([t]))[0]) / self.Cs

    def vh(self, t: float) -> float:
        if self.mu.size == 0:
            return self.v
        return self.v + (self.vh0 - self.v) * float(np.exp(-0.5 * self.mu[1] * t))

    def slowest_rate(self) -> float:
        return float(min(self.lam.min(), self.mu.min() if self.mu.size else np.inf))

    def fastest_rate(self) -> float:
        return float(max(self.lam.max(), self.mu.max() if self.mu.size else 0.0))
