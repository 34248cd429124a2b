"""Slow disturbances as stochastic processes (unit scale), sampled exactly at given times.

Each process is a linear stochastic differential equation (or a deterministic signal plus one),
integrated *exactly* between the sample times (the exact discretisation of a linear SDE:
``X[k+1] = expm(A dt) X[k] + w[k]``, ``w ~ N(0, Q(dt))`` with Van Loan's ``Q``), so the path
does not depend on a step size.  Families:

* ``ou``         first-order Gauss-Markov (Ornstein-Uhlenbeck), time constant ``tau_s``.
* ``ou2``        second-order Gauss-Markov (a noise-driven damped oscillator: smooth wander with
                 a preferred period ``period_s`` and damping ``zeta``).
* ``wiener``     a random walk (Brownian motion) from a random start, diffusing 1 unit in an hour.
* ``warmup``     an exponential settling from the run's start (``tau_s``), amplitude varying
                 from run to run, plus a weaker OU.
* ``thermostat`` the limit cycle of a bang-bang room controller: an asymmetric triangle wave
                 (period ``period_s``, duty ``duty``), low-passed by a first-order lag
                 ``filter_s`` (the package), plus a weaker OU.
* ``trend``      a linear trend with a slope drawn per run, plus a weaker OU.
* ``pink``       a sum of OU processes with log-spaced time constants (1/f-like over a band).

All are scaled so that a typical deviation over a run of a few hours is about 1.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.signal import lfilter

PROCESSES = ("ou", "ou2", "wiener", "warmup", "thermostat", "trend", "pink")


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def draw_process(rng: np.random.Generator, kinds: tuple[str, ...] = PROCESSES) -> dict:
    """A random process form (JSON-safe)."""
    kind = str(kinds[int(rng.integers(len(kinds)))])
    f: dict = {"process": kind}
    if kind == "ou":
        f["tau_s"] = _logu(rng, 900.0, 10_800.0)
    elif kind == "ou2":
        f["period_s"] = _logu(rng, 1_800.0, 14_400.0)
        f["zeta"] = float(rng.uniform(0.3, 1.2))
    elif kind == "wiener":
        f["start_sd"] = float(rng.uniform(0.0, 0.7))
    elif kind == "warmup":
        f["tau_s"] = _logu(rng, 600.0, 5_400.0)
        f["sign"] = float(rng.choice([-1.0, 1.0]))
        f["ou_ratio"] = float(rng.uniform(0.1, 0.5))
        f["ou_tau_s"] = _logu(rng, 600.0, 7_200.0)
    elif kind == "thermostat":
        f["period_s"] = _logu(rng, 600.0, 3_600.0)
        f["duty"] = float(rng.uniform(0.25, 0.75))
        f["filter_s"] = _logu(rng, 60.0, 900.0)
        f["ou_ratio"] = float(rng.uniform(0.0, 0.3))
        f["ou_tau_s"] = _logu(rng, 900.0, 7_200.0)
    elif kind == "trend":
        f["ou_ratio"] = float(rng.uniform(0.1, 0.5))
        f["ou_tau_s"] = _logu(rng, 600.0, 7_200.0)
    elif kind == "pink":
        n = int(rng.integers(3, 7))
        lo = _logu(rng, 120.0, 900.0)
        hi = _logu(rng, 7_200.0, 40_000.0)
        f["taus_s"] = [float(t) for t in np.geomspace(lo, hi, n)]
    else:  # pragma: no cover
        raise ValueError(kind)
    return f


def _ou_path(times: np.ndarray, tau: float, normals: np.ndarray, x0: float) -> np.ndarray:
    out = np.empty(times.size)
    x, t_prev = x0, 0.0
    for k, t in enumerate(times):
        a = math.exp(-(t - t_prev) / tau)
        x = a * x + math.sqrt(max(1.0 - a * a, 0.0)) * normals[k]
        out[k] = x
        t_prev = t
    return out


def _ou2_path(times: np.ndarray, period: float, zeta: float, normals: np.ndarray, x0: np.ndarray) -> np.ndarray:
    w = 2.0 * math.pi / period
    A = np.array([[0.0, 1.0], [-w * w, -2.0 * zeta * w]])
    q2 = 4.0 * zeta * w ** 3  # stationary variance of the position: 1
    BBt = np.array([[0.0, 0.0], [0.0, q2]])
    out = np.empty(times.size)
    x = x0.copy()
    t_prev = 0.0
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    for k, t in enumerate(times):
        dt = float(t - t_prev)
        key = round(dt, 9)
        if key not in cache:
            M = np.zeros((4, 4))
            M[:2, :2] = -A
            M[:2, 2:] = BBt
            M[2:, 2:] = A.T
            E = expm(M * dt)
            Phi = E[2:, 2:].T
            Q = Phi @ E[:2, 2:]
            Q = 0.5 * (Q + Q.T)
            evals, evecs = np.linalg.eigh(Q)
            L = evecs * np.sqrt(np.maximum(evals, 0.0))
            cache[key] = (Phi, L)
        Phi, L = cache[key]
        x = Phi @ x + L @ normals[k]
        out[k] = x[0]
        t_prev = t
    return out


def _triangle(t: np.ndarray, period: float, duty: float, phase: float) -> np.ndarray:
    """Asymmetric triangle wave in [-1, 1]: rises for ``duty`` of the period, falls for the rest."""
    c = np.mod(t / period + phase, 1.0)
    return np.where(c < duty, -1.0 + 2.0 * c / duty, 1.0 - 2.0 * (c - duty) / (1.0 - duty))


def _lowpass_grid(sig: np.ndarray, dt: float, tau: float, y0: float) -> np.ndarray:
    a = math.exp(-dt / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], sig, zi=[a * y0])
    return y


def sample_process(form: dict, rng: np.random.Generator, times: np.ndarray) -> np.ndarray:
    """The process at ``times`` (s from the run's start, ascending, >= 0), unit scale.

    All random numbers are drawn from ``rng`` in a fixed order: the run's own parameters first,
    then the normals of the path, one row per sample.
    """
    times = np.asarray(times, dtype=float)
    n = times.size
    kind = form["process"]
    if kind == "ou":
        x0 = float(rng.standard_normal())
        z = rng.standard_normal(n)
        return _ou_path(times, float(form["tau_s"]), z, x0)
    if kind == "ou2":
        w = 2.0 * math.pi / float(form["period_s"])
        x0 = np.array([rng.standard_normal(), w * rng.standard_normal()])
        z = rng.standard_normal((n, 2))
        return _ou2_path(times, float(form["period_s"]), float(form["zeta"]), z, x0)
    if kind == "wiener":
        x0 = float(form["start_sd"]) * float(rng.standard_normal())
        z = rng.standard_normal(n)
        dts = np.diff(np.concatenate([[0.0], times]))
        return x0 + np.cumsum(np.sqrt(dts / 3600.0) * z)
    if kind == "warmup":
        amp = float(form["sign"]) * float(rng.uniform(0.5, 1.5))
        x0 = float(rng.standard_normal())
        z = rng.standard_normal(n)
        ou = _ou_path(times, float(form["ou_tau_s"]), z, x0)
        return 1.5 * amp * np.exp(-times / float(form["tau_s"])) + float(form["ou_ratio"]) * ou
    if kind == "thermostat":
        period = float(form["period_s"]) * float(rng.uniform(0.9, 1.1))
        phase = float(rng.uniform(0.0, 1.0))
        x0 = float(rng.standard_normal())
        z = rng.standard_normal(n)
        tau_f, duty = float(form["filter_s"]), float(form["duty"])
        dt = min(5.0, period / 200.0)
        # the filter's state at the run's start: the periodic steady state (filtered from 8 periods before)
        pre = np.arange(-8.0 * period, 0.0, dt)
        y_pre = _lowpass_grid(_triangle(pre, period, duty, phase), dt, tau_f, 0.0)
        t_end = (float(times[-1]) if n else 0.0) + dt
        grid = np.arange(0.0, t_end + dt, dt)
        y = _lowpass_grid(_triangle(grid, period, duty, phase), dt, tau_f, float(y_pre[-1]))
        # normalise by the steady cycle's rms (independent of the run's length)
        cyc = _lowpass_grid(_triangle(np.arange(0.0, 4.0 * period, dt), period, duty, 0.0), dt, tau_f, 0.0)
        cyc = cyc[cyc.size // 2:]
        scale = float(np.std(cyc)) or 1.0
        ou = _ou_path(times, float(form["ou_tau_s"]), z, x0)
        return np.interp(times, grid, y) / scale + float(form["ou_ratio"]) * ou
    if kind == "trend":
        slope = float(rng.standard_normal())
        x0 = float(rng.standard_normal())
        z = rng.standard_normal(n)
        ou = _ou_path(times, float(form["ou_tau_s"]), z, x0)
        return slope * times / 3600.0 + float(form["ou_ratio"]) * ou
    if kind == "pink":
        taus = [float(t) for t in form["taus_s"]]
        x0 = rng.standard_normal(len(taus))
        z = rng.standard_normal((n, len(taus)))
        out = np.zeros(n)
        for j, tau in enumerate(taus):
            out += _ou_path(times, tau, z[:, j], float(x0[j]))
        return out / math.sqrt(len(taus))
    raise ValueError(f"unknown process {kind!r}")
