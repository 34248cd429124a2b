"""Relaxation kernels of creep, all reduced to a Prony series ``K(t) = sum_i w_i exp(-t / tau_i)``, K(0) = 1.

* ``prony``: a generalised Maxwell / Zener solid with 1-3 explicit branches;
* ``lognormal``: a log-normal spectrum of relaxation times (disordered grain-boundary sliding);
* ``power_law``: ``(1 + t / tau0)^-n``, the fractional (Scott-Blair / springpot) relaxation of a
  polymer-like or amorphous layer; its spectrum is a Gamma density of rates, discretised exactly;
* ``stretched_exp``: Kohlrausch ``exp(-(t / tau)^beta)``, fitted by non-negative least squares on a
  log-spaced grid of relaxation times.

The Prony form makes the hereditary integral a recursion (one exponential state per branch).
"""

from __future__ import annotations

import json
from functools import lru_cache

import numpy as np

TAU_GRID = np.logspace(-0.5, 5.5, 49)          # 0.3 s .. 3.7 days


def kernel_function(form: dict, t: np.ndarray) -> np.ndarray:
    """The exact kernel the form describes (for checking the Prony fit)."""
    k = form["kernel"]
    t = np.asarray(t, dtype=float)
    if k == "prony":
        return sum(w * np.exp(-t / tau) for w, tau in zip(form["weights"], form["tau_s"]))
    if k == "power_law":
        return (1.0 + t / form["tau0_s"]) ** (-form["exponent"])
    if k == "stretched_exp":
        return np.exp(-((t / form["tau_s"]) ** form["beta"]))
    if k == "lognormal":
        lt = np.log(TAU_GRID)
        w = np.exp(-0.5 * ((lt - np.log(form["median_tau_s"])) / form["sigma_ln"]) ** 2)
        w /= w.sum()
        return np.exp(-t[:, None] / TAU_GRID[None, :]) @ w
    raise ValueError(k)


@lru_cache(maxsize=256)
def _prony_cached(key: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    form = json.loads(key)
    k = form["kernel"]
    if k == "prony":
        w = np.asarray(form["weights"], float)
        return tuple((w / w.sum()).tolist()), tuple(float(x) for x in form["tau_s"])
    if k == "lognormal":
        lt = np.log(TAU_GRID)
        w = np.exp(-0.5 * ((lt - np.log(form["median_tau_s"])) / form["sigma_ln"]) ** 2)
        w /= w.sum()
        keep = w > 1e-6
        return tuple((w[keep] / w[keep].sum()).tolist()), tuple(TAU_GRID[keep].tolist())
    if k == "power_law":
        # (1 + t/tau0)^-n = int Gamma(s; n) exp(-s t / tau0) ds: rates s/tau0, log-spaced quadrature
        n, tau0 = float(form["exponent"]), float(form["tau0_s"])
        ls = np.linspace(np.log(1e-7), np.log(40.0), 80)
        s = np.exp(ls)
        from scipy.special import gammaln
        dens = np.exp(n * ls - s - gammaln(n)) * (ls[1] - ls[0])   # s^(n-1) e^-s ds, ds = s dln s
        w = dens.copy()
        w[0] += max(1.0 - dens.sum(), 0.0)            # the slower rates, lumped into the slowest branch
        w /= w.sum()
        return tuple(w.tolist()), tuple((tau0 / s).tolist())
    # stretched exponential: NNLS fit
    t = np.concatenate([[0.0], np.logspace(-1.0, 5.3, 260)])
    target = kernel_function(form, t)
    A = np.exp(-t[:, None] / TAU_GRID[None, :])
    wt = 1.0 / (0.02 + target)                        # relative accuracy where it matters
    from scipy.optimize import lsq_linear
    w = lsq_linear(A * wt[:, None], target * wt, bounds=(0.0, np.inf), method="bvls").x
    keep = w > 1e-9
    w = w[keep] / w[keep].sum()
    return tuple(w.tolist()), tuple(TAU_GRID[keep].tolist())


def prony(form: dict) -> tuple[np.ndarray, np.ndarray]:
    """Weights (sum 1) and relaxation times (s) of the form's kernel."""
    keys = ("kernel", "weights", "tau_s", "median_tau_s", "sigma_ln", "tau0_s", "exponent", "beta")
    key = json.dumps({k: form[k] for k in keys if k in form}, sort_keys=True)
    w, tau = _prony_cached(key)
    return np.array(w), np.array(tau)
