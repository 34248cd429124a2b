"""Realisations and kernels: drift paths, relaxation kernels, spectra of time constants.

Every random draw here comes from a stream named by (seed, mechanism, run): the
realisation of a mechanism never depends on its strength nor on which other
mechanisms are present.
"""

from __future__ import annotations

import zlib

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import lfilter
from scipy.special import erf, exp1

#: Time step (s) of the grid on which drift paths are generated.
DRIFT_DT_S = 5.0


def stream(seed: int, name: str, index: int = 0) -> np.random.Generator:
    """An independent random stream for ``name`` (a mechanism, ``noise``, ``session``) and ``index``."""
    tag = zlib.crc32(name.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence([0x6E_C0, int(seed) & 0xFFFFFFFF, tag, int(index)]))


def _logistic(z: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * z))


def _random_walk(rng: np.random.Generator, n: int, smooth_s: float, reversion_s: float) -> np.ndarray:
    steps = rng.normal(0.0, np.sqrt(DRIFT_DT_S), n)
    if reversion_s > 0.0:  # Ornstein-Uhlenbeck
        path = lfilter([1.0], [1.0, -np.exp(-DRIFT_DT_S / reversion_s)], steps)
    else:
        path = np.cumsum(steps)
    sigma = smooth_s / DRIFT_DT_S
    if sigma > 0.5:
        path = gaussian_filter1d(path, sigma, mode="nearest")
    return path


def drift_path(form: dict, rng: np.random.Generator, span_s: float) -> tuple[np.ndarray, np.ndarray]:
    """A dimensionless slow wander on ``[0, span_s]``: starts at 0, max |value| ~ 1 (times a random factor).

    Returns ``(grid_s, path)``; evaluate with ``np.interp``.
    """
    span_s = max(float(span_s), 10 * DRIFT_DT_S)
    grid = np.arange(0.0, span_s + 2 * DRIFT_DT_S, DRIFT_DT_S)
    n = grid.size
    kind = form["kind"]
    if kind == "random_walk":
        path = _random_walk(rng, n, form["smooth_s"], form["reversion_s"])
    elif kind == "sinusoids":
        k = int(form["n"])
        periods = np.exp(rng.uniform(np.log(form["period_min_s"]), np.log(form["period_max_s"]), k))
        amps = periods ** form["spectral_slope"] * rng.uniform(0.5, 1.0, k)
        phases = rng.uniform(0.0, 2 * np.pi, k)
        path = np.sum(amps[:, None] * np.sin(2 * np.pi * grid[None, :] / periods[:, None] + phases[:, None]), 0)
    elif kind == "jumps":
        count = max(1, int(rng.poisson(form["rate_per_h"] * span_s / 3600.0)))
        times = rng.uniform(0.0, span_s, count)
        sizes = rng.normal(0.0, 1.0, count)
        w = form["smooth_s"]
        z = (grid[None, :] - times[:, None]) / w
        if form["profile"] == "logistic":
            prof = _logistic(z)
        elif form["profile"] == "erf":
            prof = 0.5 * (1.0 + erf(z))
        else:  # a sudden slip, then settling
            prof = np.where(z > 0.0, 1.0 - np.exp(-np.maximum(z, 0.0)), 0.0)
        path = np.sum(sizes[:, None] * prof, 0)
    elif kind == "trend":
        tau = grid / span_s
        a1 = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 1.0)
        a2 = form["curvature"] * rng.normal()
        a3 = form["cubic"] * rng.normal()
        path = a1 * tau + a2 * tau**2 + a3 * tau**3
    elif kind == "settling":
        tau1 = form["tau_s"] * rng.uniform(0.7, 1.4)
        tau2 = tau1 * form["tau_ratio"]
        path = (1.0 - np.exp(-grid / tau1)) - form["overshoot"] * (1.0 - np.exp(-grid / tau2))
        path = path * rng.choice([-1.0, 1.0])
    else:
        raise ValueError(f"unknown drift kind {kind!r}")
    path = np.asarray(path, float) - path[0]
    peak = np.max(np.abs(path))
    path = path / peak if peak > 0 else path
    rw = _random_walk(rng, n, form["rw_smooth_s"], 0.0)
    rw = rw - rw[0]
    peak_rw = np.max(np.abs(rw))
    if peak_rw > 0:
        path = path + form["rw_admixture"] * rw / peak_rw
    path = path - path[0]
    peak = np.max(np.abs(path))
    path = path / peak if peak > 0 else path
    return grid, path * float(rng.lognormal(0.0, 0.3))


# ---------------------------------------------------------------------------------------------
# relaxation kernels psi(t): psi(0) = 1, decreasing to 0


def _lognormal_nodes(median: float, sigma: float, n: int = 9) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.hermite_e.hermegauss(n)
    return median * np.exp(sigma * x), w / w.sum()


def relaxation(form: dict, t: np.ndarray, scale: np.ndarray | float = 1.0) -> np.ndarray:
    """Remaining fraction ``psi(t / scale)`` of a relaxation (``t`` >= 0, s)."""
    t = np.maximum(np.asarray(t, float), 0.0) / scale
    kernel = form["kernel"]
    if kernel == "andrade_log":
        a, b = form["tau_min_s"], form["tau_max_s"]
        with np.errstate(over="ignore", divide="ignore"):
            val = (exp1(np.maximum(t, 1e-300) / b) - exp1(np.maximum(t, 1e-300) / a)) / np.log(b / a)
        return np.where(t <= 0.0, 1.0, np.clip(val, 0.0, 1.0))
    if kernel == "stretched":
        return np.exp(-((t / form["tau_s"]) ** form["beta"]))
    if kernel == "power_law":
        return (1.0 + t / form["tau0_s"]) ** (-form["m"])
    if kernel == "lognormal":
        taus, w = _lognormal_nodes(form["median_s"], form["sigma_ln"])
        return np.tensordot(w, np.exp(-t[None, ...] / taus.reshape((-1,) + (1,) * t.ndim)), 1)
    raise ValueError(f"unknown kernel {kernel!r}")


def lag_spectrum(form: dict) -> tuple[np.ndarray, np.ndarray]:
    """Time constants (s) and weights (sum 1) of the slow thermal paths."""
    spectrum = form["spectrum"]
    if spectrum == "lognormal":
        return _lognormal_nodes(form["median_s"], form["sigma_ln"], 9)
    if spectrum == "two_lognormal":
        t1, w1 = _lognormal_nodes(form["median_s"], form["sigma_ln"], 5)
        t2, w2 = _lognormal_nodes(form["median2_s"], form["sigma2_ln"], 5)
        s2 = form["share2"]
        return np.concatenate([t1, t2]), np.concatenate([(1 - s2) * w1, s2 * w2])
    taus = np.exp(np.linspace(np.log(form["tau_min_s"]), np.log(form["tau_max_s"]), 10))
    return taus, np.full(10, 0.1)
