"""Relaxation kernels as Prony series (sums of exponentials).

Every slow path and every relaxation in this generator is a kernel ``R(t)``
(``R(0) = 1``, ``R -> 0``) written as ``sum_i w_i exp(-t / tau_i)`` so that the
engine can advance its states exactly over any interval.  Kernels that are not
exponential (diffusion into a substrate, stretched exponentials, power laws) are
fitted by non-negative least squares on a logarithmic time grid.

A kernel descriptor is a JSON-safe dict: ``{"kind": ..., parameters}``:

* ``modes``:     ``taus_s`` (list), ``weights`` (list, normalised here).
* ``diffusive``: ``tau_s``: a node coupled to a semi-infinite substrate,
  ``R = exp(t/tau) erfc(sqrt(t/tau))`` (a 1/sqrt(t) tail).
* ``stretched``: ``tau_s``, ``beta`` (0 < beta <= 1): ``R = exp(-(t/tau)**beta)``.
* ``power``:     ``tau_s``, ``alpha``: ``R = (1 + t/tau)**-alpha``.
* ``logspec``:   ``tau_min_s``, ``tau_max_s``: a flat spectrum of log(tau)
  (logarithmic-in-time relaxation between the two).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import nnls
from scipy.special import erfcx

#: The longest and shortest time constants the fits use (s).
TAU_FLOOR_S = 0.2
TAU_CEIL_S = 2.0e5


def _fit(fun, tau_lo: float, tau_hi: float, n_modes: int = 14) -> tuple[np.ndarray, np.ndarray]:
    tau_lo, tau_hi = max(tau_lo, TAU_FLOOR_S), min(tau_hi, TAU_CEIL_S)
    taus = np.geomspace(tau_lo, tau_hi, n_modes)
    t = np.concatenate([[0.0], np.geomspace(tau_lo * 0.05, tau_hi * 3.0, 160)])
    target = fun(t)
    basis = np.exp(-t[:, None] / taus[None, :])
    # weight the start (R(0) = 1 exactly matters) and the log-time grid evenly
    wts = np.ones_like(t)
    wts[0] = 30.0
    w, _ = nnls(basis * wts[:, None], target * wts)
    keep = w > 1e-9
    taus, w = taus[keep], w[keep]
    return taus, w / np.sum(w)


@lru_cache(maxsize=512)
def _prony_cached(items: tuple) -> tuple[tuple[float, ...], tuple[float, ...]]:
    d = dict(items)
    kind = d["kind"]
    if kind == "modes":
        taus = np.asarray(d["taus_s"], dtype=float)
        w = np.abs(np.asarray(d["weights"], dtype=float))
        w = w / np.sum(w)
    elif kind == "diffusive":
        tau = float(d["tau_s"])
        taus, w = _fit(lambda t: erfcx(np.sqrt(t / tau)), tau * 0.02, tau * 3000.0)
    elif kind == "stretched":
        tau, beta = float(d["tau_s"]), float(d["beta"])
        taus, w = _fit(lambda t: np.exp(-np.power(t / tau, beta)), tau * 1e-3, tau * 300.0)
    elif kind == "power":
        tau, alpha = float(d["tau_s"]), float(d["alpha"])
        taus, w = _fit(lambda t: np.power(1.0 + t / tau, -alpha), tau * 0.3, tau * 1e4)
    elif kind == "logspec":
        taus = np.geomspace(float(d["tau_min_s"]), float(d["tau_max_s"]), 12)
        w = np.full(taus.size, 1.0 / taus.size)
    else:
        raise ValueError(f"unknown kernel kind {kind!r}")
    return tuple(float(x) for x in taus), tuple(float(x) for x in w)


def _freeze(desc: dict) -> tuple:
    return tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in desc.items()))


def prony(desc: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(taus_s, weights)`` of the kernel ``desc`` (weights sum to one)."""
    taus, w = _prony_cached(_freeze(desc))
    return np.array(taus), np.array(w)


def value(desc: dict, t_s: float | np.ndarray) -> np.ndarray:
    """``R(t)`` of the Prony series of ``desc``."""
    taus, w = prony(desc)
    t = np.asarray(t_s, dtype=float)
    return np.exp(-t[..., None] / taus) @ w
