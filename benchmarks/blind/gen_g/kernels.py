"""Relaxation spectra, slow drift paths and the random streams of generator G.

Everything time-dependent in this generator is built from two pieces:

* a *relaxation spectrum*: a set of time constants with non-negative weights
  summing to one, standing for a kernel (a few discrete paths, a log-normal
  spread, a stretched exponential, a diffusion tail, a log-uniform (Andrade,
  logarithmic-creep) spread).  With a spectrum every linear memory is a bank of
  first-order states, updated exactly between events.
* a *drift path*: a sum of slow components (Ornstein-Uhlenbeck wander, flicker,
  a building's air-handling cycle, a ramp, a settling after the start of a run,
  sudden steps), realised run by run from streams of their own, and continuous
  across runs.
"""

from __future__ import annotations

import functools
import zlib

import numpy as np
from scipy.optimize import nnls
from scipy.special import erfcx

_TAG = 0x67656E67  # "geng"


def _u64(x: int) -> int:
    return int(x) % (1 << 63)


def stream(seed: int, *keys: int) -> np.random.Generator:
    """An independent generator for ``seed`` and integer ``keys`` (run index, purpose, name...)."""
    return np.random.default_rng(np.random.SeedSequence([_TAG, _u64(seed), *[_u64(k) for k in keys]]))


def name_key(name: str) -> int:
    """A stable integer for a mechanism's name (not Python's salted ``hash``)."""
    return zlib.crc32(name.encode("utf-8"))


# ----------------------------------------------------------------------------------------------
# relaxation spectra
# ----------------------------------------------------------------------------------------------

def _freeze(obj):
    if isinstance(obj, dict):
        return tuple(sorted((k, _freeze(v)) for k, v in obj.items()))
    if isinstance(obj, (list, tuple)):
        return tuple(_freeze(v) for v in obj)
    return obj


def _fit(phi, tau: float, decades_lo: float = 2.5, decades_hi: float = 4.0, n: int = 44):
    """Non-negative sum of exponentials fitting the relaxation function ``phi(t)`` (phi(0) = 1)."""
    taus = tau * np.logspace(-decades_lo, decades_hi, n)
    t = tau * np.logspace(-decades_lo - 0.5, decades_hi - 0.3, 260)
    a = np.exp(-t[:, None] / taus[None, :])
    w, _ = nnls(a, phi(t))
    keep = w > 1e-6 * max(w.max(), 1e-300)
    taus, w = taus[keep], w[keep]
    return taus, w / w.sum()


@functools.lru_cache(maxsize=256)
def _spectrum(frozen) -> tuple[np.ndarray, np.ndarray]:
    spec = {k: v for k, v in frozen}
    kind = spec["kind"]
    if kind == "discrete":
        taus = np.array(spec["taus_s"], dtype=float)
        w = np.array(spec["weights"], dtype=float)
    elif kind == "lognormal":
        tau, dec = float(spec["tau_s"]), float(spec["decades"])
        x = np.linspace(-3.0, 3.0, 25)
        taus = tau * 10.0 ** (dec * x)
        w = np.exp(-0.5 * x**2)
    elif kind == "loguniform":
        taus = np.logspace(np.log10(spec["tau_min_s"]), np.log10(spec["tau_max_s"]), 24)
        w = np.ones_like(taus)
    elif kind == "stretched":
        tau, beta = float(spec["tau_s"]), float(spec["beta"])
        taus, w = _fit(lambda t: np.exp(-((t / tau) ** beta)), tau)
    elif kind == "diffusive":
        tau = float(spec["tau_s"])
        # the heat still to arrive after a power step into a half-space behind a contact
        # conductance: erfcx(sqrt(t / tau)) (a 1/sqrt(t) tail)
        taus, w = _fit(lambda t: erfcx(np.sqrt(t / tau)), tau, decades_hi=4.5)
    else:
        raise ValueError(f"unknown spectrum kind {kind!r}")
    w = np.asarray(w, dtype=float)
    return np.asarray(taus, dtype=float), w / w.sum()


def spectrum(spec: dict) -> tuple[np.ndarray, np.ndarray]:
    """(time constants in s, weights summing to one) of a spectrum description."""
    taus, w = _spectrum(_freeze(spec))
    return taus.copy(), w.copy()


def draw_spectrum(rng: np.random.Generator, tau_lo: float, tau_hi: float,
                  kinds=("discrete", "lognormal", "stretched", "diffusive", "loguniform")) -> dict:
    """A random spectrum whose characteristic times lie in ``[tau_lo, tau_hi]`` s (log-uniform)."""
    kind = str(rng.choice(list(kinds)))

    def logu(lo, hi):
        return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))

    if kind == "discrete":
        n = int(rng.integers(1, 4))
        taus = sorted(logu(tau_lo, tau_hi) for _ in range(n))
        w = rng.dirichlet(np.full(n, 1.5))
        return {"kind": kind, "taus_s": [float(t) for t in taus], "weights": [float(x) for x in w]}
    if kind == "lognormal":
        return {"kind": kind, "tau_s": logu(tau_lo, tau_hi), "decades": float(rng.uniform(0.15, 0.8))}
    if kind == "stretched":
        return {"kind": kind, "tau_s": logu(tau_lo, tau_hi), "beta": float(rng.uniform(0.3, 0.9))}
    if kind == "diffusive":
        return {"kind": kind, "tau_s": logu(tau_lo, max(tau_lo * 1.01, tau_hi / 10.0))}
    lo = logu(tau_lo, np.sqrt(tau_lo * tau_hi))
    return {"kind": "loguniform", "tau_min_s": lo, "tau_max_s": float(max(lo * 10.0, logu(np.sqrt(tau_lo * tau_hi), tau_hi)))}


# ----------------------------------------------------------------------------------------------
# slow drift paths
# ----------------------------------------------------------------------------------------------

DRIFT_KINDS = ("ou", "flicker", "cycle", "ramp", "settle", "steps")


def draw_drift(rng: np.random.Generator, kinds=DRIFT_KINDS, tau_lo: float = 300.0, tau_hi: float = 10_000.0,
               period_lo: float = 600.0, period_hi: float = 3600.0, n_max: int = 3) -> list[dict]:
    """1 to ``n_max`` slow components with relative weights (the path's unit: about one at rms)."""
    n = int(rng.integers(1, n_max + 1))
    chosen = rng.choice(list(kinds), size=n, replace=False)

    def logu(lo, hi):
        return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))

    comps = []
    for kind in chosen:
        kind = str(kind)
        c: dict = {"kind": kind, "weight": float(rng.uniform(0.3, 1.0))}
        if kind == "ou":
            c["tau_s"] = logu(tau_lo, tau_hi)
        elif kind == "flicker":
            c["tau_min_s"] = logu(tau_lo / 3.0, tau_lo * 3.0)
            c["tau_max_s"] = logu(max(tau_hi, c["tau_min_s"] * 10), max(tau_hi, c["tau_min_s"] * 10) * 5)
        elif kind == "cycle":
            c["period_s"] = logu(period_lo, period_hi)
            c["shape"] = str(rng.choice(["sine", "sawtooth", "thermostat"]))
            c["duty"] = float(rng.uniform(0.25, 0.75))
            c["period_jitter"] = float(rng.uniform(0.0, 0.15))
        elif kind == "ramp":
            c["rate_per_h"] = float(rng.uniform(0.25, 0.8))
            c["curvature"] = float(rng.uniform(-0.5, 0.5))
        elif kind == "settle":
            c["tau_s"] = logu(tau_lo / 2.0, tau_hi / 2.0)
            c["law"] = str(rng.choice(["exp", "log"]))
        elif kind == "steps":
            c["rate_per_h"] = float(rng.uniform(0.3, 2.0))
            c["relax_s"] = logu(1.0, 600.0)
        comps.append(c)
    return comps


def _cycle_wave(phase: np.ndarray, shape: str, duty: float) -> np.ndarray:
    """A periodic wave of unit rms-ish amplitude; ``phase`` in cycles."""
    f = np.mod(phase, 1.0)
    if shape == "sine":
        return np.sqrt(2.0) * np.sin(2 * np.pi * f)
    if shape == "sawtooth":  # slow warming, fast cooling when the air handler kicks in
        d = min(max(duty, 0.05), 0.95)
        up = f < d
        w = np.where(up, f / d, 1.0 - (f - d) / (1.0 - d))
        return np.sqrt(3.0) * (2.0 * w - 1.0)
    # thermostat: bang-bang heating/cooling, first-order smoothed edges
    d = min(max(duty, 0.1), 0.9)
    k = 12.0
    on = 1.0 / (1.0 + np.exp(-k * np.sin(2 * np.pi * (f - 0.5 * (1 - d)))))
    return 2.0 * (on - 0.5) * 1.2


class Drift:
    """A drift path realised run by run (call :meth:`run` for runs 0, 1, 2... in order).

    Each run's random part comes from ``stream(seed, 3, name, run)``; the session's fixed parts
    (the phase of a building cycle) from ``stream(seed, 4, name)``.  Stochastic components
    continue across the pause between runs from where the previous run left them.
    """

    def __init__(self, components: list[dict], seed: int, name: str) -> None:
        self.components = components
        self.seed, self.key = seed, name_key(name)
        w = np.array([c["weight"] for c in components], dtype=float)
        self.weights = w / np.sqrt(np.sum(w**2))
        srng = stream(seed, 4, self.key)
        self.phase0 = srng.uniform(0.0, 1.0, size=len(components))
        self.state: list = [None] * len(components)
        self.t_last: float | None = None
        self.next_run = 0

    def run(self, r: int, t: np.ndarray, run_start: float) -> np.ndarray:
        """The path (unit amplitude) at session times ``t`` (sorted) of run ``r``, which starts at ``run_start``."""
        if r != self.next_run:
            raise RuntimeError("runs must be realised in order")
        self.next_run += 1
        t = np.asarray(t, dtype=float)
        t_prev = self.t_last if self.t_last is not None else (t[0] if len(t) else run_start)
        total = np.zeros_like(t)
        for i, c in enumerate(self.components):
            sub = stream(self.seed, 3, self.key, r, i)  # each component its own stream
            total += self.weights[i] * self._component(i, c, sub, t, t_prev, run_start, r)
        if len(t):
            self.t_last = float(t[-1])
        return total

    def _component(self, i, c, rng, t, t_prev, run_start, r):
        kind = c["kind"]
        n = len(t)
        if kind in ("ou", "flicker"):
            if kind == "ou":
                taus = np.array([c["tau_s"]])
            else:
                taus = np.logspace(np.log10(c["tau_min_s"]), np.log10(c["tau_max_s"]), 5)
            amp = 1.0 / np.sqrt(len(taus))
            x0 = self.state[i]
            z0 = rng.standard_normal(len(taus))
            z = rng.standard_normal((n, len(taus)))
            x = z0.copy() if x0 is None else np.asarray(x0, dtype=float)
            out = np.empty(n)
            tp = t_prev
            for k in range(n):
                dt = max(t[k] - tp, 0.0)
                e = np.exp(-dt / taus)
                x = x * e + np.sqrt(np.maximum(1.0 - e * e, 0.0)) * z[k]
                out[k] = amp * np.sum(x)
                tp = t[k]
            self.state[i] = x
            return out
        if kind == "cycle":
            period = c["period_s"] * (1.0 + c["period_jitter"] * rng.uniform(-1.0, 1.0))
            amp = rng.uniform(0.6, 1.4)
            # the phase carries over continuously (session clock) but the period is redrawn each run
            if self.state[i] is None:
                ph0, tp0 = self.phase0[i], run_start
            else:
                ph_prev, tp_prev, per_prev = self.state[i]
                ph0, tp0 = ph_prev + (run_start - tp_prev) / per_prev, run_start
            ph = ph0 + (t - tp0) / period
            end = t[-1] if n else run_start
            self.state[i] = (ph0 + (end - tp0) / period, end, period)
            return amp * _cycle_wave(ph, c["shape"], c["duty"])
        if kind == "ramp":
            rate = c["rate_per_h"] * (1.0 if rng.random() < 0.5 else -1.0) * rng.uniform(0.4, 1.0) / 3600.0
            level = 0.0 if self.state[i] is None else self.state[i][0] + self.state[i][1] * (run_start - self.state[i][2])
            h = (t - run_start) / 3600.0
            vals = level + rate * (t - run_start) * (1.0 + c["curvature"] * h)
            end = t[-1] if n else run_start
            self.state[i] = (float(vals[-1]) if n else level, rate, end)
            return vals
        if kind == "settle":
            amp = (1.0 if rng.random() < 0.5 else -1.0) * rng.uniform(0.5, 1.5)
            tau = c["tau_s"] * np.exp(rng.uniform(-0.4, 0.4))
            dt = np.maximum(t - run_start, 0.0)
            base = 0.0 if self.state[i] is None else self.state[i]
            if c["law"] == "exp":
                vals = base + amp * (1.0 - np.exp(-dt / tau))
            else:
                vals = base + amp * np.log1p(dt / tau) / np.log1p(3.0 * 3600.0 / tau)
            self.state[i] = float(vals[-1]) if n else base
            return vals
        if kind == "steps":
            start = t_prev if self.state[i] is not None else (t[0] if n else run_start) - 1800.0
            end = t[-1] if n else run_start
            span = max(end - start, 0.0)
            m = int(rng.poisson(c["rate_per_h"] * span / 3600.0))
            times = np.sort(rng.uniform(start, end, size=m)) if m else np.zeros(0)
            jumps = rng.standard_normal(m) * 0.5
            old = [] if self.state[i] is None else self.state[i]
            events = list(old) + list(zip(times.tolist(), jumps.tolist()))
            vals = np.zeros(n)
            relax = c["relax_s"]
            for (te, j) in events:
                dt = t - te
                vals += np.where(dt > 0, j * (1.0 - np.exp(-np.maximum(dt, 0.0) / relax)), 0.0)
            # fold events long settled into one level to keep the list short
            keep, level = [], 0.0
            for (te, j) in events:
                if end - te > 20.0 * relax:
                    level += j
                else:
                    keep.append((te, j))
            if level != 0.0:
                keep.insert(0, (end - 1e9, level))
            self.state[i] = keep
            return vals
        raise ValueError(f"unknown drift component {kind!r}")
