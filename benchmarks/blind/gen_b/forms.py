"""Random forms of every mechanism of generator B (JSON-safe dicts).

A form fixes *how* a mechanism looks (kernel, shape, time scales, signs, asymmetries); it never depends on
the strength nor on the other mechanisms present.  Realisations (a drift's path) come from the seed at
simulation time, not from the form.
"""

from __future__ import annotations

import math

import numpy as np

from .physics import creep_kernel, creep_spectrum, foster_from_cauer

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "heater_aging")


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _sign(rng: np.random.Generator) -> float:
    return 1.0 if rng.random() < 0.5 else -1.0


def _pick(rng: np.random.Generator, options, p=None):
    return options[int(rng.choice(len(options), p=p))]


# ----------------------------------------------------------------------------- drift components

def _drift_components(rng: np.random.Generator, menu: dict) -> list[dict]:
    kinds = list(menu)
    n = int(rng.integers(1, 4))
    chosen = [kinds[i] for i in rng.choice(len(kinds), size=min(n, len(kinds)), replace=False)]
    comps = []
    for kind in chosen:
        c = {"kind": kind}
        c.update(menu[kind](rng))
        c["weight"] = float(rng.uniform(0.3, 1.0))
        comps.append(c)
    norm = math.sqrt(sum(c["weight"] ** 2 for c in comps))
    for c in comps:
        c["weight"] = c["weight"] / norm
    return comps


def _ou(lo, hi):
    return lambda rng: {"tau_s": _logu(rng, lo, hi)}


def _flicker(rng):
    return {"tau_min_s": _logu(rng, 30.0, 300.0), "tau_max_s": _logu(rng, 3000.0, 20000.0), "poles": 6}


def _warmup(lo, hi):
    return lambda rng: {"tau_s": _logu(rng, lo, hi), "sign": float(_pick(rng, [-1.0, 0.0, 1.0]))}


def _cycle(rng):
    return {"period_s": _logu(rng, 600.0, 2700.0), "duty": float(rng.uniform(0.2, 0.8))}


def _steps(rng):
    return {"mean_interval_s": _logu(rng, 1200.0, 7200.0)}


def _ramp(rng):
    return {}


# ----------------------------------------------------------------------------- per family

def _thermal_lag(rng):
    n = int(rng.integers(1, 4))
    taus = np.sort(np.exp(rng.uniform(math.log(3.0), math.log(1200.0), n)))
    if taus[-1] < 15.0:
        taus[-1] = _logu(rng, 15.0, 1200.0)
        taus = np.sort(taus)
    r = rng.dirichlet(np.full(n, 1.5))
    r = np.maximum(r, 0.02)
    r = r / r.sum()
    tau_k, w = foster_from_cauer(list(r), list(taus))
    gamma = 0.0 if rng.random() < 0.4 else float(rng.uniform(-2.5e-3, 2.5e-3))
    d20 = float(np.sum(w * np.exp(-20.0 / tau_k)))
    return {
        "network": "cauer_chain", "node_tau_s": [float(t) for t in taus], "node_r_frac": [float(x) for x in r],
        "mode_tau_s": [float(t) for t in tau_k], "mode_weight": [float(x) for x in w],
        "tcr_feedback_per_K": gamma,
        # slow share of the steady rise at strength 1: a full-range step leaves ~0.5 % of its rise after 20 s
        "share_at_1": float(0.005 / max(d20, 0.05)),
    }


def _creep(rng):
    kernel = _pick(rng, ["prony", "kww", "fractional", "log", "andrade"])
    f: dict = {"kernel": kernel}
    if kernel == "prony":
        m = int(rng.integers(1, 5))
        f["tau_s"] = sorted(float(x) for x in np.exp(rng.uniform(math.log(3.0), math.log(18000.0), m)))
        f["weights"] = [float(x) for x in rng.dirichlet(np.full(m, 1.2))]
    elif kernel == "kww":
        f["tau_s"], f["beta"] = _logu(rng, 30.0, 10800.0), float(rng.uniform(0.3, 0.9))
    elif kernel == "fractional":
        f["tau_s"], f["alpha"] = _logu(rng, 10.0, 7200.0), float(rng.uniform(0.25, 0.9))
    elif kernel == "log":
        f["t0_s"] = _logu(rng, 0.5, 60.0)
    else:
        f["alpha"] = float(rng.uniform(0.1, 0.4))
    tau, w = creep_spectrum(f)
    f["spectrum_tau_s"] = [float(x) for x in tau]
    f["spectrum_weight"] = [float(x) for x in w]
    f["driver"] = _pick(rng, ["total", "phase"])
    f["sign"] = _sign(rng)                          # +: keeps going; -: partial recovery (stress relaxation)
    f["rate_asym"] = float(rng.uniform(-0.6, 0.6)) if rng.random() < 0.6 else 0.0
    f["eyring"] = float(rng.uniform(1.0, 5.0)) if rng.random() < 0.5 else 0.0
    # amount at strength 1: 1.5 % of a change has crept after half an hour (kernel-normalised)
    j = float(creep_kernel(f, np.array([1800.0]))[0])
    f["fraction_at_1"] = float(0.015 / max(j, 0.2))
    return f


def _baseline(rng):
    menu = {"ou": _ou(300.0, 7200.0), "flicker": _flicker, "warmup": _warmup(300.0, 3600.0),
            "ramp": _ramp, "steps": _steps, "cycle": _cycle}
    return {"components": _drift_components(rng, menu), "rms_frac_at_1": 0.008}


def _ambient(rng):
    menu = {"ou": _ou(600.0, 10800.0), "flicker": _flicker, "warmup": _warmup(1200.0, 5400.0),
            "ramp": _ramp, "cycle": _cycle}
    return {"components": _drift_components(rng, menu), "rms_K_at_1": 0.12}


def _gain(rng):
    menu = {"ou": _ou(300.0, 7200.0), "flicker": _flicker, "warmup": _warmup(300.0, 3600.0),
            "steps": _steps, "cycle": _cycle, "ramp": _ramp}
    return {"components": _drift_components(rng, menu), "rms_rel_at_1": 0.012}


def _joule(rng):
    return {
        "tcr_saturation": float(rng.uniform(0.0, 0.4)) if rng.random() < 0.6 else 0.0,
        "cte_slope": float(rng.uniform(-0.4, 1.0)),
        "peak_frac_at_1": 0.01,
    }


def _sensor(rng):
    kind = _pick(rng, ["split_gaussian", "quadrant_tophat", "lepsd_edge", "tetralateral"])
    f: dict = {"detector": kind}
    if kind == "split_gaussian":
        f["span"], f["offset"] = float(rng.uniform(0.4, 1.3)), float(rng.uniform(-0.4, 0.4))
    elif kind == "quadrant_tophat":
        f["span"] = float(rng.uniform(0.5, 1.3))
        lim = max(0.95 - f["span"] / 2.0, 0.0)
        f["offset"] = float(rng.uniform(-lim, lim))
    elif kind == "lepsd_edge":
        f["sigma"] = float(rng.uniform(0.1, 0.4))
        f["span"], f["offset"] = float(rng.uniform(0.8, 1.6)), float(rng.uniform(-0.4, 0.4))
    else:
        f["kappa"], f["y0"] = float(rng.uniform(-0.3, 0.5)), float(rng.uniform(-0.6, 0.6))
        f["span"], f["offset"] = float(rng.uniform(0.8, 1.8)), float(rng.uniform(-0.4, 0.4))
    f["peak_frac_at_1"] = 0.01
    return f


def _reversible(rng):
    kind = _pick(rng, ["structural_sigmoid", "softening_bump", "electrostatic", "geometric", "legendre"])
    f: dict = {"kind": kind, "sign": _sign(rng), "peak_frac_at_1": 0.01}
    if kind in ("structural_sigmoid", "softening_bump"):
        f["variable"] = "temperature"
        f["center_offset_K"] = float(rng.uniform(-15.0, 15.0))
        f["width_K"] = _logu(rng, 3.0, 20.0)
    elif kind == "electrostatic":
        f["variable"] = "voltage"
        f["pull_in"] = float(rng.uniform(0.0, 0.5))
    elif kind == "geometric":
        f["variable"] = "temperature"
        f["power"] = float(rng.uniform(2.5, 6.0))
    else:
        f["variable"] = _pick(rng, ["voltage", "temperature"])
        f["coef"] = [float(x) for x in rng.standard_normal(3)]
    return f


def _interaction(rng):
    return {
        "sign": _sign(rng),
        "quadratic": float(rng.uniform(-0.4, 0.4)) if rng.random() < 0.5 else 0.0,
        "stress_free_p": float(rng.uniform(-1.0, 1.0)),
        "shift_K_at_1": 0.25,
        "max_loop_gain": 0.6,
    }


def _first_point(rng):
    return {
        "sign": _sign(rng),                 # +: overshoot along the new direction; -: lags behind
        "asym": float(rng.uniform(-1.0, 1.0)) if rng.random() < 0.6 else 0.0,
        "size_law": _pick(rng, ["const", "linear", "sqrt", "saturating"]),
        "v0_V": float(rng.uniform(0.2, 2.0)),
        "linger": float(rng.uniform(0.2, 0.7)) if rng.random() < 0.6 else 0.0,
        "amp_frac_at_1": 0.012,
    }


def _backlash(rng):
    n = int(rng.integers(1, 4))
    widths = rng.uniform(0.3, 1.5, n)
    weights = rng.dirichlet(np.full(n, 2.0))
    widths = widths / float(np.sum(weights * widths))
    return {
        "plays": [{"width": float(wd), "weight": float(wt), "asym": float(rng.uniform(-0.5, 0.5))}
                  for wd, wt in zip(widths, weights)],
        "halfwidth_frac_at_1": 0.008,
    }


def _accommodation(rng):
    pattern = _pick(rng, ["fatigue", "training_gain", "shift_up", "shift_down", "narrowing", "broadening"])
    return {
        "pattern": pattern,
        "law": _pick(rng, ["exp", "log", "power"]),
        "n0_cycles": _logu(rng, 0.5, 10.0),
        "power": float(rng.uniform(0.3, 1.0)),
        # relative change of the weights after 20 cycles at strength 1
        "change_at_1": 0.015 if pattern in ("fatigue", "training_gain") else 0.05,
    }


def _heater_aging(rng):
    return {
        "ea_eV": float(rng.uniform(0.3, 0.9)),
        "law": _pick(rng, ["saturating", "parabolic", "log", "linear"]),
        "d0_s": _logu(rng, 300.0, 10000.0),
        "sign": _sign(rng),          # +: heater anneals (R falls, more power); -: R rises (interdiffusion)
        "change_at_1": 0.003,
    }


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline, "ambient_drift": _ambient,
    "joule_power": _joule, "sensor_nonlinearity": _sensor, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain,
    "backlash": _backlash, "accommodation": _accommodation, "heater_aging": _heater_aging,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe), independent of the strength."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}; known: {sorted(_DRAW)}")
    form = _DRAW[family](rng)
    form["family"] = family
    return form
