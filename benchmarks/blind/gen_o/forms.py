"""Random *forms* of every mechanism: kernels, shapes, time scales, signs, asymmetries.

A form is a JSON-safe dict.  It never depends on the strength nor on the other
mechanisms present; the realisation of a drift (its path in a given run) is
not part of the form: it is drawn from the session's seed by ``simulate``.
The ranges below are the ones documented in ``README.md``.
"""

from __future__ import annotations

import math

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag",
    "creep",
    "baseline_drift",
    "ambient_drift",
    "joule_power",
    "sensor_nonlinearity",
    "reversible",
    "interaction",
    "first_point",
    "gain_drift",
)

#: ``spillover_fringes`` is this generator's own outside mechanism (see README.md).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "spillover_fringes")

#: Longest time scale of the slow drifts and of creep (s).
HOUR = 3600.0


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _choice(rng: np.random.Generator, options, p=None):
    i = int(rng.choice(len(options), p=p))
    return options[i]


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> float:
    return 1.0 if rng.uniform() < p_plus else -1.0


# --------------------------------------------------------------------------- drifts

def _drift_component(kind: str, rng: np.random.Generator) -> dict:
    if kind == "ou":  # stationary wander (laser pointing, air currents, electronics)
        return {"kind": kind, "tau_s": _logu(rng, 600.0, 3.0 * HOUR)}
    if kind == "random_walk":  # non-stationary wander (mechanical creep of a mount)
        return {"kind": kind, "per_sqrt_hour": float(rng.uniform(0.6, 1.0))}
    if kind == "ac_cycle":  # thermostat cycling of the lab air: asymmetric triangle, smoothed
        return {"kind": kind, "period_s": float(rng.uniform(600.0, 2400.0)),
                "duty": float(rng.uniform(0.2, 0.8)), "smooth_s": _logu(rng, 60.0, 400.0),
                "period_jitter": float(rng.uniform(0.02, 0.15))}
    if kind == "day":  # the building's day: a segment of a 24 h cycle (ramp or curvature)
        return {"kind": kind, "period_s": float(rng.uniform(20.0, 28.0) * HOUR)}
    if kind == "warmup":  # electronics / laser warm-up, mount settling after set-up
        return {"kind": kind, "tau_s": _logu(rng, 300.0, 3600.0), "sign": _sign(rng)}
    if kind == "hops":  # laser mode hops between two states, re-stabilised over minutes
        return {"kind": kind, "mean_dwell_s": float(rng.uniform(1200.0, 5400.0)),
                "smooth_s": _logu(rng, 60.0, 400.0)}
    if kind == "events":  # door opened / someone leaned on the table: dip and recovery
        return {"kind": kind, "rate_per_h": float(rng.uniform(0.3, 1.2)),
                "rise_s": _logu(rng, 60.0, 300.0), "recover_s": _logu(rng, 300.0, 1800.0),
                "sign": _sign(rng, 0.35)}
    if kind == "settling":  # mount touched: a permanent offset reached over minutes
        return {"kind": kind, "rate_per_h": float(rng.uniform(0.3, 1.0)),
                "settle_s": _logu(rng, 120.0, 900.0)}
    raise ValueError(kind)


_DRIFT_KINDS = {
    "baseline_drift": (("ou", "random_walk", "warmup", "hops", "settling", "ac_cycle", "day"),
                       (0.22, 0.14, 0.2, 0.1, 0.1, 0.14, 0.1)),
    "gain_drift": (("ou", "random_walk", "warmup", "hops", "ac_cycle", "day"),
                   (0.25, 0.12, 0.25, 0.14, 0.14, 0.1)),
    "ambient_drift": (("ac_cycle", "day", "ou", "warmup", "events"),
                      (0.3, 0.2, 0.2, 0.15, 0.15)),
}


def _drift_form(family: str, rng: np.random.Generator) -> dict:
    kinds, p = _DRIFT_KINDS[family]
    n = int(rng.choice([1, 2, 3], p=[0.35, 0.45, 0.2]))
    chosen = list(rng.choice(len(kinds), size=n, replace=False, p=np.array(p) / np.sum(p)))
    raw = rng.dirichlet(np.ones(n) * 1.5)
    weights = np.sqrt(raw)  # unit total power
    comps = []
    for i, w in zip(chosen, weights):
        c = _drift_component(kinds[int(i)], rng)
        c["weight"] = float(w)
        comps.append(c)
    form = {"components": comps}
    if family == "ambient_drift":
        # K per unit strength, as a fraction of the film's transition width
        form["kelvin_per_width"] = float(rng.uniform(0.03, 0.05))
    elif family == "baseline_drift":
        form["swing_fraction"] = float(rng.uniform(0.008, 0.014))
    else:
        form["swing_fraction"] = float(rng.uniform(0.008, 0.014))
    return form


# --------------------------------------------------------------------------- kernels

def _prony_exponentials(rng, lo, hi, n):
    taus = np.sort([_logu(rng, lo, hi) for _ in range(n)])
    for i in range(1, n):  # keep the paths distinct (a factor of 3 at least)
        taus[i] = max(taus[i], 3.0 * taus[i - 1])
    taus = np.minimum(taus, hi)
    w = rng.uniform(0.3, 1.0, n)
    return [float(t) for t in taus], [float(x) for x in w / w.sum()]


def _thermal_lag(rng):
    kernel = _choice(rng, ["single", "double", "triple", "diffusive"], p=[0.3, 0.3, 0.15, 0.25])
    if kernel == "diffusive":
        t0, t1 = _logu(rng, 2.0, 20.0), _logu(rng, 60.0, 600.0)
        taus = np.geomspace(t0, t1, 6)
        gamma = float(rng.uniform(0.0, 0.5))
        w = taus ** (-gamma)
        taus, w = [float(t) for t in taus], [float(x) for x in w / w.sum()]
        form = {"kernel": kernel, "diffusion_exponent": gamma}
    else:
        n = {"single": 1, "double": 2, "triple": 3}[kernel]
        taus, w = _prony_exponentials(rng, 2.0, 600.0, n)
        form = {"kernel": kernel}
    mode = _choice(rng, ["lag", "lead", "mixed"], p=[0.6, 0.15, 0.25])
    signs = np.ones(len(taus))
    if mode == "lead":
        signs[:] = -1.0
    elif mode == "mixed":
        if len(taus) == 1:  # a second, faster path of the other sign
            fast = max(2.0, taus[0] / _logu(rng, 3.0, 20.0))
            taus = [float(fast)] + taus
            w = [float(rng.uniform(0.3, 0.7))]
            w = w + [1.0 - w[0]]
            signs = np.ones(2)
        k = int(rng.integers(1, len(taus)))  # the fast paths one sign, the slow ones the other
        s_fast = _sign(rng, 0.5)
        signs[:k], signs[k:] = s_fast, -s_fast
    form.update({
        "mode": mode,
        "taus_s": [float(t) for t in taus],
        "weights": [float(a * s) for a, s in zip(w, signs)],
        # fraction of the steady rise carried by the slow paths, per unit strength
        "fraction_per_strength": float(rng.uniform(0.004, 0.008)),
    })
    return form


def _creep(rng):
    kernel = _choice(rng, ["exponentials", "logarithmic", "stretched"], p=[0.4, 0.3, 0.3])
    lo, hi = 3.0, 3.0 * HOUR
    if kernel == "exponentials":
        taus, w = _prony_exponentials(rng, lo, hi, int(rng.integers(1, 4)))
        extra = {}
    elif kernel == "logarithmic":  # equal weight per decade: creep ~ log(t)
        t0, t1 = _logu(rng, 3.0, 30.0), _logu(rng, 0.5 * HOUR, 3.0 * HOUR)
        taus = np.geomspace(t0, t1, 8)
        w = np.ones(8) / 8
        taus, w = [float(t) for t in taus], [float(x) for x in w]
        extra = {}
    else:  # stretched exponential: log-normal spread of relaxation times
        centre = _logu(rng, 30.0, 3000.0)
        width = float(rng.uniform(0.4, 1.2))
        lt = np.linspace(-2.0 * width, 2.0 * width, 9) + math.log10(centre)
        lt = np.clip(lt, math.log10(lo), math.log10(hi))
        w = np.exp(-0.5 * ((lt - math.log10(centre)) / width) ** 2)
        taus, w = [float(10 ** x) for x in lt], [float(x) for x in w / w.sum()]
        extra = {"centre_s": centre, "width_decades": width}
    law = _choice(rng, ["linear", "power", "saturating"], p=[0.4, 0.3, 0.3])
    law_form = {"law": law}
    if law == "power":
        law_form["exponent"] = float(rng.uniform(0.6, 1.5))
    elif law == "saturating":
        law_form["saturation_swing_fraction"] = float(rng.uniform(0.05, 0.4))
    if rng.uniform() < 0.35:
        up, down = 1.0, 1.0
    else:
        r = math.exp(rng.uniform(-math.log(2.5), math.log(2.5)))
        up, down = math.sqrt(r), 1.0 / math.sqrt(r)
    return {
        "kernel": kernel, **extra, "taus_s": taus, "weights": w, **law_form,
        "up_factor": float(up), "down_factor": float(down),
        "direction": _choice(rng, ["forward", "recovery"], p=[0.75, 0.25]),
        "source": _choice(rng, ["deflection", "phase"], p=[0.6, 0.4]),
        "fraction_per_strength": float(rng.uniform(0.01, 0.02)),
    }


def _joule_power(rng):
    return {
        "anchor": _choice(rng, ["end", "lsq", "transition"], p=[0.35, 0.4, 0.25]),
        # relative change of the expansion coefficient over the full rise
        "alpha_change": float(rng.uniform(-0.3, 0.8)),
        "swing_fraction": float(rng.uniform(0.010, 0.016)),
    }


def _sensor_nonlinearity(rng):
    shape = _choice(rng, ["tanh", "arctan", "algebraic", "asym_tanh", "exp"],
                    p=[0.25, 0.15, 0.15, 0.25, 0.2])
    form = {"shape": shape, "centre_offset": float(rng.uniform(-0.8, 0.8)),
            "swing_fraction": float(rng.uniform(0.012, 0.022))}
    if shape == "asym_tanh":
        form["scale_pos"] = float(rng.uniform(0.3, 1.7))
        form["scale_neg"] = float(rng.uniform(0.3, 1.7))
    if shape == "exp":
        form["q"] = float(_sign(rng) * rng.uniform(0.5, 1.5))
    return form


def _reversible(rng):
    shape = _choice(rng, ["sigmoid", "bump", "power", "saturating"], p=[0.3, 0.25, 0.25, 0.2])
    form = {"shape": shape, "input": _choice(rng, ["heater", "temperature"], p=[0.4, 0.6]),
            "sign": _sign(rng), "swing_fraction": float(rng.uniform(0.01, 0.02))}
    if shape in ("sigmoid", "bump"):
        form["centre_offset_V"] = float(rng.uniform(-0.6, 0.6))
        form["width_V"] = float(rng.uniform(0.15, 1.0))
    elif shape == "power":
        form["exponent"] = float(rng.uniform(2.0, 4.0))
    else:
        form["scale_V"] = float(rng.uniform(1.0, 4.0))
    return form


def _interaction(rng):
    shape = _choice(rng, ["linear", "cubic"], p=[0.65, 0.35])
    form = {"shape": shape, "sign": _sign(rng, 0.6),
            "loop_gain_per_strength": float(rng.uniform(0.05, 0.1))}
    if shape == "cubic":
        form["cubic"] = float(rng.uniform(0.5, 2.0))
    return form


def _first_point(rng):
    size = _choice(rng, ["none", "linear", "saturating", "sqrt"], p=[0.25, 0.25, 0.3, 0.2])
    form = {"size_law": size,
            "convention": _choice(rng, ["along", "against", "fixed"], p=[0.4, 0.4, 0.2]),
            "swing_fraction": float(rng.uniform(0.01, 0.022))}
    if size == "saturating":
        form["size_scale_V"] = _logu(rng, 0.05, 1.0)
    ratio = float(rng.uniform(0.25, 1.0))
    if rng.uniform() < 0.5:
        form["up_factor"], form["down_factor"] = 1.0, ratio
    else:
        form["up_factor"], form["down_factor"] = ratio, 1.0
    form["linger"] = 0.0 if rng.uniform() < 0.4 else float(rng.uniform(0.2, 0.6))
    return form


def _backlash(rng):
    kind = _choice(rng, ["play", "distributed", "stick_slip"], p=[0.45, 0.35, 0.2])
    form = {"kind": kind, "asymmetry": float(rng.uniform(-0.5, 0.5)),
            "half_width_swing_fraction": float(rng.uniform(0.006, 0.014))}
    if kind == "distributed":
        form["profile"] = _choice(rng, ["uniform", "triangular", "exponential"])
    if kind == "stick_slip":
        form["slip_keep"] = float(rng.uniform(0.0, 0.7))
    return form


_PATTERNS = ("fatigue", "shift", "width", "heating_branch", "cooling_branch")


def _accommodation(rng):
    law = _choice(rng, ["saturating", "log", "power", "linear"], p=[0.35, 0.25, 0.25, 0.15])
    form = {"law": law, "prior_cycles": 0.0 if rng.uniform() < 0.5 else _logu(rng, 1.0, 200.0)}
    if law in ("saturating", "log"):
        form["cycles_scale"] = _logu(rng, 2.0, 40.0)
    if law == "power":
        form["exponent"] = float(rng.uniform(0.3, 1.0))
    n = int(rng.choice([1, 2], p=[0.6, 0.4]))
    idx = rng.choice(len(_PATTERNS), size=n, replace=False)
    pats = []
    for i in idx:
        name = _PATTERNS[int(i)]
        p_plus = {"fatigue": 0.2, "shift": 0.35, "width": 0.4}.get(name, 0.5)
        pats.append({"pattern": name, "sign": _sign(rng, p_plus),
                     "weight": float(rng.uniform(0.4, 1.0))})
    form["patterns"] = pats
    form["swing_fraction"] = float(rng.uniform(0.015, 0.03))
    return form


def _spillover_fringes(rng):
    form = {
        "period_um": _logu(rng, 0.7, 5.0),
        "phase_rad": float(rng.uniform(0.0, 2 * math.pi)),
        "shape": _choice(rng, ["sine", "airy"], p=[0.6, 0.4]),
        "power_phase_rad": float(rng.uniform(0.0, 3.0)),
        "drift_rad_per_h": float(rng.uniform(-1.5, 1.5)),
        "envelope": _choice(rng, ["none", "gaussian"], p=[0.5, 0.5]),
        "swing_fraction": float(rng.uniform(0.008, 0.014)),
    }
    if form["shape"] == "airy":
        form["finesse"] = float(rng.uniform(0.5, 4.0))
    if form["envelope"] == "gaussian":
        form["envelope_centre"] = float(rng.uniform(-0.8, 0.8))
        form["envelope_width_swing"] = float(rng.uniform(0.5, 2.0))
    return form


_DRAW = {
    "thermal_lag": _thermal_lag,
    "creep": _creep,
    "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity,
    "reversible": _reversible,
    "interaction": _interaction,
    "first_point": _first_point,
    "backlash": _backlash,
    "accommodation": _accommodation,
    "spillover_fringes": _spillover_fringes,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe).

    Does not depend on the strength nor on the other mechanisms present.
    """
    if family in _DRIFT_KINDS:
        return _drift_form(family, rng)
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}")
    return _DRAW[family](rng)


__all__ = ["HOUR", "LIBRARY", "OUTSIDE", "draw_form"]
