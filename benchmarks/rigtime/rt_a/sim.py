"""Rig-time device rt_a: the base VO2 device plus the film's and the beam's thermal dynamics.

Physics (see ``README.md`` in this folder for the reasons and the ranges):

* The heater, beam, film, substrate and package form a passive thermal RC
  network driven by the heater's Joule power.  Seen from the heater, a
  passive RC network's thermal impedance is a *Foster* sum of first-order
  modes with positive weights, ``Z(t) = sum_k w_k (1 - exp(-t / tau_k))``
  (the standard compact thermal model of power devices).  Every mode state
  ``m_k`` (in units of the steady rise, here squared equivalent volts:
  ``rise_K = kelvin_per_V2 * m``) relaxes to the set-point's steady rise
  ``v**2``: ``dm_k/dt = rate (v**2 - m_k) / tau_k``.
* The film sits on the beam a little away from the heater: its temperature
  is ``sum_k w_k m_k`` seen through a short transfer lag ``film_lag_s`` (a
  first-order stage, 0 for none).  The beam's mean temperature, which the
  linear thermal-expansion term follows, uses the same modes with its own
  weights (identical on the slow modes, redistributed among the fast ones)
  and its own lag (no longer than the film's).  The impulse responses are
  non-negative, so a step from steady state never overshoots.
* Heating and cooling differ: every conductance grows (or shrinks) with the
  temperature the network is held at, ``rate = (1 + gamma rise) / (1 + gamma
  rise_ref)`` evaluated at the set-point's steady rise (the linearisation
  about the equilibrium being approached: with ``gamma > 0`` a hot
  set-point is reached faster than a cold one).  The latent heat of the
  transition adds ``latent_K`` kelvin-equivalents of sensible heat over the
  whole transition: a step that must switch a fraction ``df`` of the film
  over a rise ``dT`` runs slower by ``1 + latent_K df / dT`` (capped).
* The hysterons follow the film's current equivalent voltage through every
  extreme of its path (found on a dense time grid and refined); each PSD
  reading is the average of the deflection over its own averaging window
  (3-node Gauss-Legendre quadrature of the window while the film moves).
* Optional extras (one, at most 0.1 % of the phase swing): a slow sinusoidal
  drift of the PSD's zero, or a visco-elastic creep after each change of
  the deflection.

All linear dynamics are in closed form per set-point; only the hysteresis is
stepped, with :class:`~benchmarks.rigtime.rt_a.preisach.FastPreisach` (the
base device's phase, exactly, in O(1) per move).
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from scipy.optimize import brentq

from benchmarks.blind import base

from .preisach import FastPreisach, tables

#: Film rise (K) at which ``tau_s`` is defined: about the VO2 transition (~70 C on a ~25 C bench).
REFERENCE_RISE_K = 45.0
#: Rises beyond this (K) no longer change the conductances (the factor saturates).
RISE_CAP_K = 150.0
#: Sub-samples of a reading's averaging window while the film moves (Gauss-Legendre nodes and weights).
SUBSAMPLES = 3
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(SUBSAMPLES)
#: Points of the dense time grid used to find the extremes of the film's path in one set-point.
DENSE_POINTS = 64

_NOISE_TAG = 0x72745F61  # "rt_a"
_UNIT = np.linspace(0.0, 1.0, DENSE_POINTS)
_EMPTY = np.empty(0)
_TABLES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


# ----------------------------------------------------------------------------- forms


def _loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _distinct(t: float, others: list[float], ratio: float) -> bool:
    return all(max(t, o) / min(t, o) >= ratio for o in others if o > 0)


def draw_form(tau_s: float, rng: np.random.Generator, extras: bool = True) -> dict:
    """A random thermal-dynamics form (JSON-safe) whose characteristic time constant is ``tau_s`` (s).

    ``tau_s`` is the time constant of the slowest Foster mode carrying at least
    20 % of the film's steady rise, with the network linearised at a film rise
    of ``REFERENCE_RISE_K`` (the transition region) and no latent heat.
    """
    tau_s = float(tau_s)
    if not (tau_s > 0 and math.isfinite(tau_s)):
        raise ValueError(f"tau_s must be a positive time, got {tau_s!r}")
    # Small slow package/substrate mode, and a very fast mode (the beam's own capacity / the heater).
    has_pkg = rng.random() < 0.6
    w_pkg = float(rng.uniform(0.005, 0.08)) if has_pkg else 0.0
    t_pkg = tau_s * _loguniform(rng, 1.5, 4.0) if has_pkg else 0.0
    has_fast = rng.random() < 0.5
    w_fast = float(rng.uniform(0.02, 0.2)) if has_fast else 0.0
    t_fast = tau_s * _loguniform(rng, 0.002, 0.04) if has_fast else 0.0
    # One to three dominant modes: the main one at tau_s, the others faster.
    n_dom = int(rng.integers(1, 4))
    rest = 1.0 - w_pkg - w_fast
    w_main = rest if n_dom == 1 else rest * float(rng.uniform(0.35, 0.9))
    w_others = (rng.dirichlet(np.ones(n_dom - 1)) * (rest - w_main)).tolist() if n_dom > 1 else []
    t_others: list[float] = []
    while len(t_others) < n_dom - 1:
        t = tau_s * _loguniform(rng, 0.08, 0.6)
        if _distinct(t, t_others + [tau_s], 1.25):
            t_others.append(t)
    taus = [tau_s] + t_others
    weights = [w_main] + [float(w) for w in w_others]
    if has_fast:
        taus.append(t_fast)
        weights.append(w_fast)
    if has_pkg:
        taus.append(t_pkg)
        weights.append(w_pkg)
    order = np.argsort(taus)[::-1]
    taus = [float(taus[i]) for i in order]
    weights = [float(weights[i]) for i in order]
    total = sum(weights)
    weights = [w / total for w in weights]
    # Beam weights: the same on the slow modes (>= tau_s), redistributed among the faster ones.
    beam = list(weights)
    fast_idx = [i for i, t in enumerate(taus) if t < tau_s]
    if len(fast_idx) > 1:
        group = sum(weights[i] for i in fast_idx)
        pert = np.array([weights[i] for i in fast_idx]) * np.exp(rng.normal(0.0, 0.4, len(fast_idx)))
        pert *= group / pert.sum()
        for i, w in zip(fast_idx, pert):
            beam[i] = float(w)
    # Transfer lags (heater -> film, heater -> beam mean); distinct from every mode.
    film_lag = 0.0
    if rng.random() < 0.6:
        for _ in range(100):
            lag = tau_s * _loguniform(rng, 0.005, 0.08)
            if _distinct(lag, taus, 1.1):
                film_lag = lag
                break
    beam_lag = 0.0
    if film_lag > 0 and rng.random() < 0.7:
        lag = film_lag * float(rng.uniform(0.1, 1.0))
        if _distinct(lag, taus, 1.1):
            beam_lag = lag
    # Heating/cooling asymmetry and latent heat.
    gamma = float(rng.uniform(-0.002, 0.006))
    latent = float(rng.uniform(0.5, 3.0)) if rng.random() < 0.7 else 0.0
    form = {
        "generator": "rt_a",
        "tau_s": tau_s,
        "modes_tau_s": taus,
        "film_weights": weights,
        "beam_weights": beam,
        "film_lag_s": float(film_lag),
        "beam_lag_s": float(beam_lag),
        "gamma_per_K": gamma,
        "reference_rise_K": REFERENCE_RISE_K,
        "rise_cap_K": RISE_CAP_K,
        "latent_K": latent,
        "latent_max_stretch": 1.0 + latent / 2.0,
        "extra": None,
    }
    if extras:
        if rng.random() < 0.5:
            form["extra"] = {
                "kind": "drift",
                "amplitude_rel": float(rng.uniform(0.0001, 0.0005)),
                "period_s": _loguniform(rng, 600.0, 7200.0),
                "phase_rad": float(rng.uniform(0.0, 2.0 * math.pi)),
            }
        else:
            form["extra"] = {
                "kind": "creep",
                "amplitude_rel": float(rng.uniform(0.0002, 0.001)),
                "tau_s": _loguniform(rng, 10.0, 300.0),
            }
    return form


def instant_form() -> dict:
    """A form with infinitely fast dynamics and no extras: the clean device."""
    return {
        "generator": "rt_a", "tau_s": 0.0, "modes_tau_s": [], "film_weights": [], "beam_weights": [],
        "film_lag_s": 0.0, "beam_lag_s": 0.0, "gamma_per_K": 0.0, "reference_rise_K": REFERENCE_RISE_K,
        "rise_cap_K": RISE_CAP_K, "latent_K": 0.0, "latent_max_stretch": 1.0, "extra": None,
    }


def _rate_factor(form: dict, rise_K: float) -> float:
    g = float(form["gamma_per_K"])
    r = min(max(float(rise_K), 0.0), float(form["rise_cap_K"]))
    return (1.0 + g * r) / (1.0 + g * float(form["reference_rise_K"]))


def _complement(taus: np.ndarray, weights: np.ndarray, lag: float) -> tuple[np.ndarray, np.ndarray]:
    """Exponents and coefficients of ``1 - step response`` (at rate 1): ``g(t) = sum c exp(-t / tau)``."""
    if lag > 0:
        c = weights * taus / (taus - lag)
        return np.append(taus, lag), np.append(c, 1.0 - c.sum())
    return taus, weights


def settling_time_s(form: dict, tolerance: float) -> float:
    """Longest time (s) after any set-point step until the film's equivalent voltage stays within ``tolerance``
    (a fraction of the step) of its new steady state.

    From a steady state the film's response is ``old + (new - old) (1 - g(t))`` in rise with ``g``
    decreasing monotonically from 1 to 0 (a passive network: non-negative impulse response).  In
    equivalent volts (``x = sqrt(rise)``) the worst step is a step down to 0 V, where the remaining
    fraction is ``sqrt(g)``: the time is that of ``g(t) = tolerance**2``.  The bound takes the slowest
    rate over the range (coldest or hottest set-point) and the largest latent-heat stretch.
    """
    taus = np.asarray(form["modes_tau_s"], dtype=float)
    if taus.size == 0 or tolerance >= 1.0:
        return 0.0
    tol = float(tolerance)
    if not tol > 0:
        raise ValueError("tolerance must be positive")
    # In equivalent volts x = sqrt(rise): a step v1 -> v2 leaves |x - v2| / |v1 - v2| =
    # (sqrt(r^2 + (1 - r^2) g) - r) / (1 - r) (r = v2 / v1), largest (sqrt(g)) for a step down to 0 V.
    tol = tol * tol
    tt, cc = _complement(taus, np.asarray(form["film_weights"], dtype=float), float(form["film_lag_s"]))

    def g(t: float) -> float:
        return float(np.dot(cc, np.exp(-t / tt))) - tol

    hi = float(tt.max()) * (math.log(1.0 / tol) + math.log(max(np.abs(cc).sum(), 1.0)) + 5.0)
    while g(hi) > 0:
        hi *= 2.0
    t = 0.0 if g(0.0) <= 0 else brentq(g, 0.0, hi, xtol=1e-12 * hi, rtol=1e-13)
    slowest = min(_rate_factor(form, 0.0), _rate_factor(form, float(form["rise_cap_K"])))
    return float(t * float(form["latent_max_stretch"]) / slowest)


# ----------------------------------------------------------------------------- simulation


def _device_tables(device):
    try:
        return _TABLES[device]
    except (KeyError, TypeError):
        pass
    t = tables(device)
    try:
        _TABLES[device] = t
    except TypeError:
        pass
    return t


def _coefficients(D: np.ndarray, y: float, u: float, taus: np.ndarray, w: np.ndarray, lag: float):
    """Exponents (time constants at rate 1) and coefficients of a temperature's deviation from ``u``."""
    if lag > 0:
        a = w * D * taus / (taus - lag)
        return np.append(taus, lag), np.append(a, (y - u) - a.sum())
    return taus, w * D


def _evaluate(t: np.ndarray, rates: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    return np.exp(-np.multiply.outer(t, rates)) @ coeffs


def _extreme(t1: float, t3: float, rates: np.ndarray, coeffs: np.ndarray) -> float:
    """The time of the extreme of ``sum coeffs exp(-rates t)`` whose slope changes sign in ``[t1, t3]``."""
    slope = coeffs * rates

    def deriv(t: float) -> float:
        return float(slope @ np.exp(-rates * t))

    try:
        return float(brentq(deriv, t1, t3, xtol=1e-14 * max(t3, 1e-300), rtol=1e-15))
    except ValueError:
        return t1 if abs(deriv(t1)) < abs(deriv(t3)) else t3


def simulate(device, schedule: dict, form: dict, seed: int, noise_um: float | None) -> dict:
    """One run.  See the module docstring and ``README.md``.

    schedule: ``{"v_V": (n,), "dwell_s": (n,), "readings": (n,), "measured": (n,), "reading_s": float}``.
    Returns ``{"t_s", "v_V", "y_um"}``: the time of each point's last reading (end of its averaging window;
    the end of the dwell for a point not measured), the set-points, the recorded means (NaN if not measured).
    A measured point with 0 readings takes one reading.
    """
    v_all = np.asarray(schedule["v_V"], dtype=float).ravel()
    n = v_all.size
    dwell = np.broadcast_to(np.asarray(schedule["dwell_s"], dtype=float), (n,))
    readings = np.broadcast_to(np.asarray(schedule["readings"], dtype=int), (n,))
    measured = np.broadcast_to(np.asarray(schedule["measured"], dtype=bool), (n,))
    reading_s = float(schedule["reading_s"])
    if np.any(dwell < 0) or reading_s < 0:
        raise ValueError("dwell_s and reading_s must be >= 0")
    k_eff = np.where(measured, np.maximum(readings, 1), 0)

    tab = _device_tables(device)
    hyst = FastPreisach(tables=tab)
    swing = tab.swing
    kpv2 = float(device.kelvin_per_V2)
    bias, therm = float(device.bias_um), float(device.thermal_um_per_V)

    taus = np.asarray(form["modes_tau_s"], dtype=float)
    wf = np.asarray(form["film_weights"], dtype=float)
    wb = np.asarray(form["beam_weights"], dtype=float)
    lag_f, lag_b = float(form["film_lag_s"]), float(form["beam_lag_s"])
    latent, cap = float(form["latent_K"]), float(form["latent_max_stretch"])
    dynamic = taus.size > 0
    extra = form.get("extra") or None

    # Noise: from the seed only (never the form): one standard normal per reading, in order.
    z = np.random.default_rng(np.random.SeedSequence([_NOISE_TAG, int(seed)])).standard_normal(int(k_eff.sum()))

    m = np.zeros(taus.size)  # mode states (V^2), ambient
    y_f = 0.0  # film (lagged) rise, V^2
    y_b = 0.0  # beam (lagged) rise, V^2
    phase_now = hyst.value()
    t0 = 0.0
    creep_q = bias + phase_now  # the deflection the creep relaxes from (initial steady deflection)
    if extra is not None and extra["kind"] == "creep":
        span = 2.0 * swing + abs(therm) * float(device.v_max_V)
        creep_c = float(extra["amplitude_rel"]) * swing / span if span > 0 else 0.0
    t_out = np.empty(n)
    y_out = np.full(n, np.nan)
    zi = 0
    offs = 0.5 * (_GL_NODES + 1.0)
    gl_w = 0.5 * _GL_WEIGHTS

    for idx in range(n):
        v = float(v_all[idx])
        u = v * v
        K = int(k_eff[idx])
        T = float(dwell[idx]) + K * reading_s
        if dynamic:
            film_now = y_f if lag_f > 0 else float(wf @ m)
            D = m - u
            tf, cf = _coefficients(D, y_f, u, taus, wf, lag_f)
            tb, cb = _coefficients(D, y_b, u, taus, wb, lag_b)
            still = not (np.any(cf) or np.any(cb))
        else:
            still = True
        sample_t = None
        if K:
            sub = SUBSAMPLES if not still else 1
            sample_t = float(dwell[idx]) + reading_s * (
                np.arange(K)[:, None] + (offs if sub > 1 else np.array([0.5]))[None, :]).ravel()
        if still:
            phase_end = hyst.move(v)  # the film is (or, instant, jumps) at the set-point
            values = None
            if K:
                values = np.full(sample_t.size, bias + therm * v + phase_end)
            vth_end = v
        else:
            rate = _rate_factor(form, kpv2 * u)
            if latent > 0 and swing > 0:
                df = abs(hyst.peek(v) - hyst.value()) / (2.0 * swing)
                drise = kpv2 * abs(u - film_now)
                rate /= 1.0 + min(latent * df / max(drise, 1e-12), cap - 1.0)
            rf, rb = rate / tf, rate / tb
            # the film on a dense grid (to find the extremes of its path), at the samples and at the end
            tmin = 0.02 / float(rf.max())
            if T > tmin:
                tg = tmin * np.exp(math.log(T / tmin) * _UNIT)
                tg[0] = 0.0
            else:
                tg = np.linspace(0.0, T, 9)
            st = sample_t if K else _EMPTY
            ng, ns = tg.size, st.size
            E = np.exp(-np.multiply.outer(np.concatenate([tg, st, [T]]), rf))
            fq = E @ cf
            fbq = _evaluate(np.concatenate([st, [T]]), rb, cb)
            fg, fs, end_f = fq[:ng], fq[ng:ng + ns], float(fq[-1])
            fb_end = float(fbq[-1])
            ext_t, ext_f = [], []
            if T > 0:
                # the film's slope on the grid: every sign change brackets one extreme
                slope = -(E[:ng] @ (cf * rf))
                for i in np.nonzero(slope[:-1] * slope[1:] < 0)[0].tolist():
                    tv = _extreme(float(tg[i]), float(tg[i + 1]), rf, cf)
                    ext_t.append(tv)
                    ext_f.append(float(cf @ np.exp(-rf * tv)))
            # move the hysterons through the extremes, the samples and the end, in time order
            times = np.concatenate([ext_t, st, [T]]) if T > 0 else np.concatenate([ext_t, st])
            devs = np.concatenate([ext_f, fs, [end_f]]) if T > 0 else np.concatenate([ext_f, fs])
            xs = np.where(devs == 0.0, v, np.sqrt(np.maximum(u + devs, 0.0)))
            order = np.argsort(times, kind="stable").tolist()
            xs = xs.tolist()
            first = len(ext_t)
            phases = np.empty(ns)
            phase_end = phase_now
            for j in order:
                phase_end = hyst.move(xs[j])
                if first <= j < first + ns:
                    phases[j - first] = phase_end
            if K:
                vth = np.sqrt(np.maximum(u + fbq[:-1], 0.0))
                values = bias + therm * vth + phases
            else:
                values = None
            # advance the state to the end of the set-point
            em = np.exp(-(rate * T) / taus)
            D_end = D * em
            m = u + D_end
            y_f = u + end_f
            y_b = u + fb_end
            vth_end = v if fb_end == 0.0 else math.sqrt(max(u + fb_end, 0.0))
        if still and dynamic:
            m = np.full(taus.size, u)
            y_f = y_b = u
        phase_now = phase_end
        if K:
            if extra is not None:
                ts_abs = t0 + sample_t
                if extra["kind"] == "drift":
                    A = float(extra["amplitude_rel"]) * swing
                    w = 2.0 * math.pi / float(extra["period_s"])
                    ph0 = float(extra["phase_rad"])
                    values = values + A * (np.sin(w * ts_abs + ph0) - math.sin(ph0))
                else:
                    U_end = bias + therm * vth_end + phase_end
                    values = values - creep_c * (U_end - creep_q) * np.exp(-sample_t / float(extra["tau_s"]))
            # mean of the readings, each the (quadrature) average over its own window
            y = float(np.mean(values)) if values.size == K else float(
                (values.reshape(K, -1) @ gl_w).mean())
            if noise_um is not None:
                y += float(noise_um) * float(z[zi:zi + K].mean())
            zi += K
            y_out[idx] = y
        if extra is not None and extra["kind"] == "creep":
            U_end = bias + therm * vth_end + phase_end
            creep_q = U_end + (creep_q - U_end) * math.exp(-T / float(extra["tau_s"]))
        t0 += T
        t_out[idx] = t0
    return {"t_s": t_out, "v_V": v_all.copy(), "y_um": y_out}


__all__ = ["draw_form", "instant_form", "settling_time_s", "simulate", "REFERENCE_RISE_K"]
