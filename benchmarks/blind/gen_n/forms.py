"""``draw_form``: a random physical form of each mechanism (JSON-safe, strength-free).

The form fixes *how* a mechanism looks on a device (kernel, time scales, shape,
signs, asymmetries).  The realisation of anything random in time (a drift's path)
is drawn later, in ``simulate``, from the session seed.  The ranges and the
reasons for them are in README.md.
"""

from __future__ import annotations

import numpy as np

from .names import ALL
from .paths import draw_path_desc
from .streams import loguniform, sign


def _pick(rng: np.random.Generator, options: tuple[str, ...], p: tuple[float, ...] | None = None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


def _thermal_lag(rng):
    kind = _pick(rng, ("modes", "diffusive", "stretched"), (0.45, 0.30, 0.25))
    if kind == "modes":
        # die (s), die attach / package base (tens of s), package body and lid (minutes),
        # board / fixture (tens of minutes)
        bands = [(3.0, 20.0), (20.0, 120.0), (120.0, 900.0), (900.0, 2400.0)]
        n = int(rng.integers(1, 4))
        chosen = sorted(rng.choice(len(bands), size=n, replace=False).tolist())
        kernel = {"kind": "modes", "taus_s": [loguniform(rng, *bands[i]) for i in chosen],
                  "weights": [float(x) for x in rng.dirichlet(np.ones(n))]}
    elif kind == "diffusive":
        kernel = {"kind": "diffusive", "tau_s": loguniform(rng, 2.0, 200.0)}
    else:
        kernel = {"kind": "stretched", "tau_s": loguniform(rng, 10.0, 600.0), "beta": float(rng.uniform(0.35, 0.9))}
    # +1: the film lags its steady state (heat still flowing into substrate and package);
    # -1: it overshoots and relaxes back (a voltage-driven heater whose resistance rises as the
    # substrate warms: the power sags over the slow path's time)
    return {"kernel": kernel, "sign": sign(rng, 0.75)}


def _creep(rng):
    kind = _pick(rng, ("modes", "logspec", "power", "stretched"))
    if kind == "modes":
        n = int(rng.integers(2, 5))
        # one mode at least is slow (minutes to hours): the film's and the beam's visco-elastic tail
        taus = [loguniform(rng, 60.0, 14_400.0)] + [loguniform(rng, 2.0, 14_400.0) for _ in range(n - 1)]
        kernel = {"kind": "modes", "taus_s": sorted(taus),
                  "weights": [float(x) for x in rng.dirichlet(np.ones(n))]}
    elif kind == "logspec":
        kernel = {"kind": "logspec", "tau_min_s": loguniform(rng, 1.0, 60.0), "tau_max_s": loguniform(rng, 1800.0, 14_400.0)}
    elif kind == "power":
        kernel = {"kind": "power", "tau_s": loguniform(rng, 1.0, 30.0), "alpha": float(rng.uniform(0.15, 0.6))}
    else:
        kernel = {"kind": "stretched", "tau_s": loguniform(rng, 60.0, 3600.0), "beta": float(rng.uniform(0.3, 0.7))}
    law = _pick(rng, ("linear", "eyring"))
    size = {"law": law}
    if law == "eyring":
        size["x0"] = loguniform(rng, 0.03, 0.4)  # in units of the output swing
    # relaxation times' factor after an up- or a down-change (one direction slower)
    slow = loguniform(rng, 1.0, 4.0) if rng.uniform() < 0.6 else 1.0
    up, down = (slow, 1.0) if rng.uniform() < 0.5 else (1.0, slow)
    activation = 0.0 if rng.uniform() < 0.4 else float(rng.uniform(0.2, 1.5))
    return {"kernel": kernel, "source": _pick(rng, ("total", "phase")), "sign": sign(rng, 0.65),
            "up": up, "down": down, "size": size, "activation": activation}


def _baseline_drift(rng):
    return {"path": draw_path_desc(rng, ("spectral", "warmup", "ramp", "cycle", "settle")),
            "stage": _pick(rng, ("spot", "electronics"))}


def _ambient_drift(rng):
    return {"path": draw_path_desc(rng, ("spectral", "warmup", "ramp", "cycle")),
            "package_tau_s": loguniform(rng, 60.0, 1800.0)}


def _joule_power(rng):
    return {"v_ref_V": float(rng.uniform(3.0, 6.0)), "beta": float(rng.uniform(-0.3, 0.8))}


def _sensor_nonlinearity(rng):
    kind = _pick(rng, ("tanh", "sinh", "exp", "rational"), (0.35, 0.15, 0.3, 0.2))
    form = {"kind": kind, "center_frac": float(rng.uniform(-1.3, 1.3))}
    if kind == "rational":
        form["q"] = float(rng.uniform(2.0, 4.0))
    if kind == "exp":
        form["sign"] = sign(rng)
    return form


def _reversible(rng):
    kind = _pick(rng, ("sigmoid", "power", "bump", "saturating", "poly"))
    form = {"kind": kind, "argument": _pick(rng, ("voltage", "temperature")), "sign": sign(rng)}
    if kind == "sigmoid":
        form["center_shift_V"] = float(rng.uniform(-0.6, 0.6))  # from the transition's centre
        form["width_V"] = float(rng.uniform(0.2, 1.2))
    elif kind == "power":
        form["p"] = float(rng.uniform(1.0, 3.5))
    elif kind == "bump":
        form["center_V"] = float(rng.uniform(1.5, 5.5))
        form["width_V"] = float(rng.uniform(0.3, 1.5))
    elif kind == "saturating":
        form["scale_V"] = float(rng.uniform(0.8, 4.0))
    else:
        form["coeffs"] = [float(x) for x in rng.normal(0.0, 1.0, 3)]
    return form


def _interaction(rng):
    return {"sign": sign(rng, 0.6), "reference": _pick(rng, ("insulating", "midpoint"))}


def _first_point(rng):
    s_up = sign(rng)
    s_down = s_up if rng.uniform() < 0.5 else -s_up
    law = _pick(rng, ("flat", "power", "saturating"))
    size = {"law": law}
    if law == "power":
        size["p"] = float(rng.uniform(0.2, 0.7))
    elif law == "saturating":
        size["step0_V"] = loguniform(rng, 0.02, 1.0)
    linger = 0.0 if rng.uniform() < 0.35 else float(rng.uniform(0.1, 0.6))
    return {"up": s_up * float(rng.uniform(0.4, 1.0)), "down": s_down * float(rng.uniform(0.4, 1.0)),
            "size": size, "linger": linger}


def _gain_drift(rng):
    return {"path": draw_path_desc(rng, ("spectral", "warmup", "ramp", "cycle"))}


def _backlash(rng):
    return {"kind": _pick(rng, ("sharp", "distributed")), "asymmetry": float(rng.uniform(0.5, 1.0)),
            "low_side_wider": bool(rng.uniform() < 0.5), "start": _pick(rng, ("centred", "low", "high"))}


def _accommodation(rng):
    kind = _pick(rng, ("amplitude", "sharpen", "broaden"))
    law = _pick(rng, ("exp", "log", "power"))
    form = {"kind": kind, "law": law, "cycles0": loguniform(rng, 2.0, 50.0), "prior_cycles": loguniform(rng, 0.5, 50.0)}
    if kind == "amplitude":
        form["sign"] = sign(rng)  # +1 training (loop grows), -1 fatigue
    else:
        form["exponent"] = float(rng.uniform(1.3, 2.0)) if kind == "sharpen" else float(rng.uniform(0.4, 0.75))
    if law == "power":
        form["a"] = float(rng.uniform(0.3, 0.8))
    return form


def _conductance_aging(rng):
    recovery = bool(rng.uniform() < 0.5)
    return {"law": _pick(rng, ("exp", "sqrt", "log")), "dose0_h": loguniform(rng, 0.3, 5.0),
            "hot_exponent": float(rng.uniform(1.0, 3.0)), "sign": sign(rng, 0.6),
            "recovery_tau_s": loguniform(rng, 300.0, 3600.0) if recovery else None}


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain_drift,
    "backlash": _backlash, "accommodation": _accommodation, "conductance_aging": _conductance_aging,
}
assert set(_DRAW) == set(ALL)


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of ``family`` (JSON-safe); independent of the strength and of other mechanisms."""
    if family not in _DRAW:
        raise KeyError(f"unknown mechanism {family!r}; known: {', '.join(ALL)}")
    return _DRAW[family](rng)
