"""Random *forms* of every mechanism (JSON-safe dicts): kernels, shapes, time scales, signs.

A form never depends on the strength nor on the device; everything device-dependent
(the output swing, the transition's position and slope) is resolved at simulation time.
See README.md for the physics behind each family and its ranges.
"""

from __future__ import annotations

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
#: ``heater_anneal`` is this lab's own outside mechanism (burn-in of the thin-film heater).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "heater_anneal")


def _lu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _pick(rng: np.random.Generator, options, p=None):
    return options[int(rng.choice(len(options), p=p))]


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> int:
    return 1 if rng.random() < p_plus else -1


# --------------------------------------------------------------------------- drift paths

def _path_component(kind: str, rng: np.random.Generator, role: str) -> dict:
    """One slow wandering component (the random path itself is drawn from the seed)."""
    if kind == "random_walk":
        return {"kind": kind, "smooth_s": _lu(rng, 60.0, 900.0)}
    if kind == "ou":
        return {"kind": kind, "corr_s": _lu(rng, 600.0, 7200.0)}
    if kind == "warmup":
        # electronics / laser switched on at every run start; relaxes back in the gap
        return {"kind": kind, "tau_s": _lu(rng, 300.0, 4000.0), "sign": _sign(rng),
                "wander": _u(rng, 0.0, 0.3)}
    if kind == "periodic":
        # HVAC cycling of the room / the optical table
        return {"kind": kind, "period_s": _lu(rng, 600.0, 3600.0), "harmonic": _u(rng, 0.0, 0.5),
                "period_jitter": _u(rng, 0.0, 0.25), "trend": _u(rng, 0.0, 0.5)}
    if kind == "trend":
        return {"kind": kind, "degree": int(rng.integers(1, 4))}
    if kind == "settling":
        # mechanical settling of the lever / a step of the room's set-point, each relaxing
        return {"kind": kind, "rate_per_h": _u(rng, 0.2, 2.0), "tau_s": _lu(rng, 120.0, 1800.0),
                "run_start_step": _u(rng, 0.0, 1.0) if role != "ambient" else 0.0}
    raise ValueError(kind)


def _path_form(rng: np.random.Generator, kinds: list[str], p: list[float], role: str) -> dict:
    if rng.random() < 0.25:
        a, b = rng.choice(len(kinds), size=2, replace=False, p=p)
        w = _u(rng, 0.3, 0.7)
        return {"kind": "mixture", "weights": [w, 1.0 - w],
                "components": [_path_component(kinds[int(a)], rng, role),
                               _path_component(kinds[int(b)], rng, role)]}
    return _path_component(_pick(rng, kinds, p), rng, role)


# --------------------------------------------------------------------------- library

def _thermal_lag(rng):
    kind = _pick(rng, ["paths", "spread", "slab"], [0.45, 0.3, 0.25])
    if kind == "paths":
        n = int(rng.integers(1, 4))
        form = {"kernel": kind, "taus_s": sorted(_lu(rng, 2.0, 900.0) for _ in range(n)),
                "weights": [float(w) for w in rng.dirichlet(np.ones(n))]}
    elif kind == "spread":
        form = {"kernel": kind, "tau_median_s": _lu(rng, 5.0, 400.0), "sigma_ln": _u(rng, 0.5, 2.0)}
    else:
        form = {"kernel": kind, "tau0_s": _lu(rng, 10.0, 1500.0)}
    form["sign"] = _pick(rng, ["lag", "overshoot", "mixed"], [0.6, 0.15, 0.25])
    if form["sign"] == "mixed":
        # the heater's TCR under voltage drive: power sags as the heater's mount warms up
        form["tcr_tau_s"] = _lu(rng, 5.0, 300.0)
        form["tcr_ratio"] = _u(rng, 0.2, 0.8)
    # convection / radiation: the slow paths speed up at high temperature
    form["tau_temp_coeff"] = _u(rng, 0.0, 0.6) if rng.random() < 0.5 else 0.0
    return form


def _creep(rng):
    kernel = _pick(rng, ["exp_modes", "log_uniform", "power", "stretched"])
    if kernel == "exp_modes":
        n = int(rng.integers(1, 4))
        k = {"taus_s": sorted(_lu(rng, 3.0, 10800.0) for _ in range(n)),
             "weights": [float(w) for w in rng.dirichlet(np.ones(n))]}
    elif kernel == "log_uniform":
        k = {"tau_lo_s": _lu(rng, 1.0, 30.0), "tau_hi_s": _lu(rng, 1800.0, 18000.0)}
    elif kernel == "power":
        k = {"tau0_s": _lu(rng, 1.0, 60.0), "alpha": _u(rng, 0.15, 0.8)}
    else:
        k = {"tau_s": _lu(rng, 20.0, 3000.0), "beta": _u(rng, 0.3, 0.8)}
    size = _pick(rng, ["linear", "saturating", "power"], [0.4, 0.3, 0.3])
    return {"kernel": kernel, **k, "size_law": size,
            "size_scale_frac": _u(rng, 0.05, 0.5), "size_power": _u(rng, 0.6, 1.6),
            "sign": _sign(rng, 0.7),  # +1: approaches the new shape from the old side
            "asym": _u(rng, -0.3, 0.3),
            "source": _pick(rng, ["total", "phase"], [0.6, 0.4])}


def _baseline_drift(rng):
    return {"path": _path_form(rng, ["random_walk", "ou", "warmup", "periodic", "trend", "settling"],
                               [0.2, 0.2, 0.2, 0.1, 0.15, 0.15], "baseline")}


def _ambient_drift(rng):
    return {"path": _path_form(rng, ["ou", "periodic", "trend", "random_walk", "settling"],
                               [0.25, 0.25, 0.2, 0.15, 0.15], "ambient"),
            "package_tau_s": _lu(rng, 60.0, 1800.0),
            "expansion_coupling": _u(rng, 0.2, 1.0) if rng.random() < 0.5 else 0.0}


def _joule_power(rng):
    shape = _pick(rng, ["power", "alpha_T", "lossy"], [0.4, 0.35, 0.25])
    form = {"shape": shape}
    if shape == "alpha_T":
        form["gamma"] = _u(rng, -0.5, 1.5)
    elif shape == "lossy":
        form["beta"] = _u(rng, 0.3, 2.0)
    return form


def _sensor_nonlinearity(rng):
    return {"shape": _pick(rng, ["tanh", "sinh", "exp", "erf", "rational"], [0.25, 0.2, 0.2, 0.15, 0.2]),
            "direction": _sign(rng),  # for "exp": which side compresses
            "centre_offset": _u(rng, -1.2, 1.2)}


def _reversible(rng):
    shape = _pick(rng, ["sigmoid", "bump", "skew_bump", "knee", "cubic"])
    return {"shape": shape, "input": _pick(rng, ["voltage", "temperature"]),
            "centre_rel": _u(rng, -1.5, 1.5), "width_V": _lu(rng, 0.15, 1.5),
            "skew": _u(rng, 0.3, 3.0), "sign": _sign(rng)}


def _interaction(rng):
    return {"space": _pick(rng, ["voltage", "temperature"]), "sign": _sign(rng, 0.6),
            "reference": _pick(rng, ["centre", "insulating", "metallic"], [0.5, 0.3, 0.2]),
            "cubic": _u(rng, -0.3, 0.3) if rng.random() < 0.3 else 0.0}


def _first_point(rng):
    return {"direction": _pick(rng, ["same", "signed", "up_only", "down_only"], [0.35, 0.35, 0.15, 0.15]),
            "sign": _sign(rng), "asym": _u(rng, -0.5, 0.5),
            "size_law": _pick(rng, ["none", "saturating", "power"]),
            "size_v0_V": _lu(rng, 0.03, 1.0), "size_power": _u(rng, 0.3, 1.0),
            "linger": 0.0 if rng.random() < 0.5 else _u(rng, 0.2, 0.7),
            "jitter": _u(rng, 0.0, 0.3)}


def _gain_drift(rng):
    return {"path": _path_form(rng, ["warmup", "ou", "periodic", "trend", "random_walk", "settling"],
                               [0.25, 0.2, 0.15, 0.15, 0.1, 0.15], "gain")}


# --------------------------------------------------------------------------- outside

def _backlash(rng):
    kind = _pick(rng, ["play", "distributed", "dahl"], [0.4, 0.35, 0.25])
    form = {"kind": kind, "initial": _pick(rng, ["down", "centre", "up"], [0.6, 0.25, 0.15])}
    if kind == "distributed":
        form["n_plays"] = int(rng.integers(3, 7))
        form["decay"] = _u(rng, 0.0, 2.0)
    if kind == "dahl":
        form["sharpness"] = _u(rng, 1.0, 4.0)
    return form


def _accommodation(rng):
    return {"pattern": _pick(rng, ["amplitude", "shift", "width", "sharpen"]),
            "sign": _sign(rng),
            "kinetics": _pick(rng, ["saturating", "log", "power"]),
            "n0_cycles": _lu(rng, 2.0, 60.0), "power": _u(rng, 0.3, 1.0),
            "prior_cycles": _u(rng, 0.0, 20.0) if rng.random() < 0.5 else 0.0,
            "counting": _pick(rng, ["variation", "miner"]), "miner_exponent": _u(rng, 1.5, 3.0)}


def _heater_anneal(rng):
    return {"sign": _sign(rng, 0.65),  # +1: resistance falls (anneal) -> more power at a set voltage
            "dose": _pick(rng, ["energy", "arrhenius", "current"]),
            "arrhenius_K": _u(rng, 8.0, 25.0), "current_power": _u(rng, 2.0, 4.0),
            "kinetics": _pick(rng, ["saturating", "log", "power"]),
            "d0_h": _lu(rng, 0.1, 3.0), "power": _u(rng, 0.3, 0.7),
            "prior_h": _u(rng, 0.0, 1.0) if rng.random() < 0.4 else 0.0}


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain_drift,
    "backlash": _backlash, "accommodation": _accommodation, "heater_anneal": _heater_anneal,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe).  Independent of the strength."""
    if family not in _DRAW:
        raise KeyError(f"unknown mechanism {family!r}")
    return _DRAW[family](rng)
