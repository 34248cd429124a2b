"""Drawing a thermal-dynamics form (a distributed cantilever) around a characteristic time ``tau_s``."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from .thermal import Network

#: Largest rate (1/K) at which a VO2 film's transformed fraction changes with temperature on the
#: base devices' major loop is about 0.15 / K; the latent secant is capped at this slope.
LATENT_SLOPE_CAP_PER_K = 0.2
#: Weight threshold defining tau_s: the slowest mode carrying at least this share of the film's rise.
TAU_WEIGHT = 0.2


def instant_form() -> dict:
    """Infinitely fast dynamics, no extras: the base device at every reading."""
    return {"kind": "instant", "tau_s": 0.0, "extra": None}


def _loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def film_output(net: Network) -> np.ndarray:
    """The share-weighted mean of the film patches (a row on the nodes)."""
    return net.share @ net.H[: net.M]


def defining_mode(net: Network, C: np.ndarray | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """``(tau, taus, weights)``: tau of the slowest mode carrying >= 20 % of the film's rise."""
    taus, w = net.step_weights(net.C0 if C is None else C, film_output(net))
    big = w >= TAU_WEIGHT
    tau = float(taus[big].max()) if np.any(big) else float(taus[np.argmax(w)])
    return tau, taus, w


def _build(p: dict) -> Network:
    return Network(p)


def draw_form(tau_s: float, rng: np.random.Generator, extras: bool = True) -> dict:
    """A random distributed-cantilever thermal form (JSON-safe) whose characteristic time is ``tau_s``."""
    tau_s = float(tau_s)
    if not tau_s > 0.0:
        raise ValueError("tau_s must be positive")
    for _attempt in range(200):
        p: dict = {"kind": "beam", "tau_s": tau_s}
        p["cells"] = int(rng.integers(10, 25))
        if rng.uniform() < 0.5:  # heater at the root (a resistor near the anchor)
            p["heater_layout"] = "root"
            p["heater"] = [0.0, float(rng.uniform(0.08, 0.35))]
        else:  # a meander along most of the beam
            p["heater_layout"] = "distributed"
            a = float(rng.uniform(0.0, 0.15))
            p["heater"] = [a, float(rng.uniform(max(a + 0.4, 0.6), 1.0))]
        p["heater_cap_extra"] = float(rng.uniform(0.0, 0.5))
        p["anchor_G"] = _loguniform(rng, 0.5, 20.0)
        p["loss_G"] = _loguniform(rng, 0.02, 1.5)
        if rng.uniform() < 0.5:  # a mirror paddle at the tip: capacity and surface loss
            pc = float(rng.uniform(0.02, 0.3))
            p["paddle_cap"] = pc
            p["paddle_loss_G"] = float(p["loss_G"] * pc * rng.uniform(0.5, 2.0))
        else:
            p["paddle_cap"] = 0.0
            p["paddle_loss_G"] = 0.0
        f0 = float(rng.uniform(0.0, 0.4))
        p["film"] = [f0, float(rng.uniform(max(f0 + 0.4, 0.8), 1.0))]
        p["patches"] = int(rng.integers(1, 5))
        p["time_scale"] = 1.0
        p["package"] = None
        p["cp_per_K"] = float(rng.uniform(4e-4, 1.5e-3))
        p["latent_K"] = float(rng.uniform(2.0, 12.0)) if rng.uniform() < 0.8 else 0.0
        p["latent_slope_cap_per_K"] = LATENT_SLOPE_CAP_PER_K
        want_pkg = rng.uniform() < 0.6
        w_pkg = float(rng.uniform(0.005, 0.08))
        r_pkg = float(rng.uniform(1.5, 5.0))
        want_drv = rng.uniform() < 0.7
        tau_up = tau_s * _loguniform(rng, 1e-4, 1e-2)
        down = float(rng.uniform(1.0, 3.0))
        p["psd_duty"] = float(rng.uniform(0.5, 1.0))
        extra_kind = str(rng.choice(["drift", "creep"]))
        extra_u = rng.uniform(size=8)

        net = _build(p)
        # plausibility: the hottest node at most 40 % hotter than the film's mean, every patch
        # at least half of it (the film's equivalent-voltage map is the base device's)
        if net.gamma.max() > 1.4 or net.gain[: net.M].min() < 0.5:
            continue
        if want_pkg:
            def weight(logR: float) -> float:
                q = dict(p, package={"R": math.exp(logR), "C": 1.0})
                nq = Network(q)
                # film rise with the package, per unit power, relative to the grounded anchor
                film = float(film_output(nq) @ nq._solve_ss(_unit_b(nq)))
                return 1.0 - base_film / film - w_pkg

            base_film = float(film_output(net) @ net._solve_ss(_unit_b(net)))
            try:
                logR = brentq(weight, math.log(1e-6), math.log(1e4), xtol=1e-10)
            except ValueError:
                continue
            R = math.exp(logR)

            def ratio(logC: float) -> float:
                q = dict(p, package={"R": R, "C": math.exp(logC)})
                nq = Network(q)
                tau, taus, _ = defining_mode(nq)
                return float(taus.max()) / tau - r_pkg

            try:
                logC = brentq(ratio, math.log(1e-4), math.log(1e6), xtol=1e-10)
            except ValueError:
                continue
            p["package"] = {"R": R, "C": math.exp(logC), "weight": w_pkg, "tau_ratio": r_pkg}
            net = Network(p)
            if abs(ratio(logC)) > 0.05 * r_pkg:
                continue
            taus_p, w_p = net.step_weights(net.C0, film_output(net))
            if w_p[np.argmax(taus_p)] > 0.12:  # the package mode must stay a small slow tail
                continue
        tau0, taus, w = defining_mode(net)
        p["time_scale"] = tau_s / tau0
        net = Network(p)
        tau1, taus, w = defining_mode(net)
        if abs(tau1 / tau_s - 1.0) > 1e-9:
            continue
        p["driver"] = {"tau_up_s": tau_up, "tau_down_s": tau_up * down} if want_drv else None
        order = np.argsort(-taus)
        p["modes"] = {"tau_s": [float(x) for x in taus[order][:6]],
                      "weight": [float(x) for x in w[order][:6]]}
        p["extra"] = None
        if extras:
            if extra_kind == "drift":
                k = 3
                wts = extra_u[:k] / extra_u[:k].sum()
                p["extra"] = {
                    "kind": "drift",
                    "amp_frac": float(2e-4 + 8e-4 * extra_u[3]),
                    "periods_s": [float(tau_s * 10 ** (1.0 + 2.0 * u)) for u in extra_u[4:7]],
                    "phases": [float(2 * math.pi * u) for u in (extra_u[7], extra_u[0], extra_u[1])],
                    "weights": [float(x) for x in wts],
                }
            else:
                p["extra"] = {
                    "kind": "creep",
                    "amp_frac": float(2e-4 + 8e-4 * extra_u[3]),
                    "tau_s": float(tau_s * 10 ** (-0.3 + 1.3 * extra_u[4])),
                }
        return p
    raise RuntimeError("could not draw a plausible form")


def _unit_b(net: Network) -> np.ndarray:
    """The heater's power distribution, unit total (independent of the film normalisation)."""
    return net.b / net.b.sum()
