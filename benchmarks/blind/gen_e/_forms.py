"""Random *forms* of every mechanism (JSON-safe dicts), drawn from broad physical families.

A form never depends on the strength nor on the other mechanisms present; amplitudes are stored as the
value "at strength 1" and scaled (continuously, monotonically) by the strength in the simulator.
"""

from __future__ import annotations

import math

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "heater_aging")


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _sign(rng: np.random.Generator) -> int:
    return int(1 if rng.random() < 0.5 else -1)


def _choice(rng: np.random.Generator, options, p=None):
    i = int(rng.choice(len(options), p=p))
    return options[i]


# ---------------------------------------------------------------------------------------------- thermal
def _thermal_lag(rng):
    kind = _choice(rng, ["ladder", "diffusive"], p=[0.65, 0.35])
    if kind == "ladder":
        n = int(rng.integers(1, 4))
        bands = [(2.0, 60.0), (30.0, 900.0), (300.0, 5400.0)]
        # which of the three physical paths (chip, package, holder/board) are present
        which = sorted(rng.choice(3, size=n, replace=False).tolist())
        tau = [_logu(rng, *bands[i]) for i in which]
        share = rng.dirichlet(np.ones(n) * 1.5).tolist()
    else:
        n = int(rng.integers(6, 11))
        total = _logu(rng, 60.0, 3600.0)          # diffusion time of the substrate slab R_s C_s
        tau = [total / n**2] * n                   # each segment's own R C
        share = [1.0 / n] * n
    return {
        "kind": kind,
        "node_tau_s": [float(t) for t in tau],
        "resistance_share": [float(s) for s in share],
        "slow_fraction_at_1": _logu(rng, 2e-3, 8e-3),
        "tcr_per_K": float(rng.uniform(-1.0e-3, 4.0e-3)),
        "series_ratio": _logu(rng, 0.1, 10.0),
        "convective_weight": float(rng.uniform(0.0, 0.5)),
        "radiative_weight": float(rng.uniform(0.0, 0.3)),
    }


def _ambient_drift(rng):
    comps = []
    pool = ["ou", "hvac", "trend", "flicker", "diurnal"]
    k = int(rng.integers(1, 4))
    for name in rng.choice(pool, size=k, replace=False).tolist():
        w = float(rng.uniform(0.3, 1.0))
        if name == "ou":
            comps.append({"kind": "ou", "weight": w, "tau_s": _logu(rng, 600.0, 10800.0)})
        elif name == "hvac":
            comps.append({"kind": "hvac", "weight": w, "period_s": _logu(rng, 600.0, 3600.0),
                          "shape": _choice(rng, ["sine", "triangle", "sawtooth"]),
                          "duty": float(rng.uniform(0.2, 0.8))})
        elif name == "trend":
            comps.append({"kind": "trend", "weight": w, "sign": _sign(rng), "curvature": float(rng.uniform(-0.5, 0.5))})
        elif name == "flicker":
            comps.append({"kind": "flicker", "weight": w, "alpha": float(rng.uniform(1.0, 2.0))})
        else:
            comps.append({"kind": "diurnal", "weight": w, "phase": float(rng.uniform(0, 2 * math.pi))})
    return {"components": comps, "package_tau_s": _logu(rng, 60.0, 1200.0),
            "peak_K_at_1": _logu(rng, 0.08, 0.3)}


def _heater_aging(rng):
    return {
        "activation_eV": float(rng.uniform(0.5, 1.2)),
        "hotspot_factor": float(rng.uniform(1.0, 1.4)),
        "kinetics": _choice(rng, ["first_order", "parabolic", "logarithmic"]),
        "dose_scale_h": _logu(rng, 0.2, 3.0),
        "sign": _sign(rng),
        "power_change_at_1": _logu(rng, 4e-3, 1.2e-2),
    }


# ---------------------------------------------------------------------------------------------- film
def _interaction(rng):
    return {
        "units": _choice(rng, ["temperature", "voltage"], p=[0.7, 0.3]),
        "sign": _sign(rng),
        "gain_at_1": _logu(rng, 0.015, 0.06),
        "quadratic": float(rng.uniform(-0.2, 0.2)),
        "reference": _choice(rng, ["insulating", "midpoint", "metallic"]),
    }


def _accommodation(rng):
    mask = _choice(rng, ["uniform", "width", "centre", "grains", "window"])
    form = {
        "mask": mask,
        "mask_sign": _sign(rng),
        "kinetics": _choice(rng, ["saturating", "power", "logarithmic"]),
        "cycles_scale": _logu(rng, 1.0, 30.0),
        "power": float(rng.uniform(0.3, 1.0)),
        # a uniform mask changes the whole transformation strain; the others redistribute weight
        "amplitude_at_1": _logu(rng, 0.008, 0.025) if mask == "uniform" else _logu(rng, 0.04, 0.12),
        "mask_seed": int(rng.integers(0, 2**31 - 1)),
    }
    if mask == "window":
        form["window_centre"] = float(rng.uniform(0.0, 1.0))     # position in the transition's range
        form["window_width"] = float(rng.uniform(0.1, 0.4))
    if mask == "grains":
        form["grain_correlation"] = float(rng.uniform(0.0, 3.0))  # cells of smoothing
    return form


# ---------------------------------------------------------------------------------------------- deflection
def _joule_power(rng):
    form = {"beta": float(rng.uniform(-0.6, 1.5)), "step": 0.0, "step_width_K": 0.0,
            "peak_frac_at_1": _logu(rng, 0.006, 0.02)}
    if rng.random() < 0.5:
        form["step"] = float(rng.uniform(-0.4, 0.4))
        form["step_width_K"] = float(rng.uniform(2.0, 10.0))
    return form


def _reversible(rng):
    kind = _choice(rng, ["precursor_sigmoid", "softening_peak", "elastic_poly", "saturating_rise"])
    form = {"kind": kind, "sign": _sign(rng), "peak_frac_at_1": _logu(rng, 0.006, 0.02),
            "variable": "temperature"}
    if kind in ("precursor_sigmoid", "softening_peak"):
        form["offset_K"] = float(rng.uniform(-8.0, 8.0))
        form["width_factor"] = float(rng.uniform(1.5, 5.0))
        form["profile"] = _choice(rng, ["gaussian", "lorentzian"]) if kind == "softening_peak" else "tanh"
    elif kind == "elastic_poly":
        form["c2"] = float(rng.uniform(-1.0, 1.0))
        form["c3"] = float(rng.uniform(-1.0, 1.0))
    else:
        form["scale"] = float(rng.uniform(0.2, 1.5))
        form["variable"] = _choice(rng, ["temperature", "heater_voltage"])
    return form


def _creep(rng):
    kind = _choice(rng, ["prony", "lognormal", "power_law", "stretched_exp"])
    form = {"kernel": kind}
    if kind == "prony":
        n = int(rng.integers(1, 4))
        form["tau_s"] = sorted(_logu(rng, 2.0, 10800.0) for _ in range(n))
        form["weights"] = rng.dirichlet(np.ones(n)).tolist()
    elif kind == "lognormal":
        form["median_tau_s"] = _logu(rng, 20.0, 3600.0)
        form["sigma_ln"] = float(rng.uniform(0.5, 2.5))
    elif kind == "power_law":
        form["tau0_s"] = _logu(rng, 1.0, 60.0)
        form["exponent"] = float(rng.uniform(0.1, 0.8))
    else:
        form["tau_s"] = _logu(rng, 20.0, 7200.0)
        form["beta"] = float(rng.uniform(0.3, 0.9))
    form["driver"] = _choice(rng, ["phase", "deflection"], p=[0.6, 0.4])
    form["size_law"] = _choice(rng, ["linear", "power", "saturating"])
    form["size_power"] = float(rng.uniform(0.7, 1.3))
    form["saturation_frac"] = float(rng.uniform(0.05, 0.5))
    form["sign"] = _sign(rng)
    form["down_ratio"] = _logu(rng, 0.4, 2.5)
    form["amplitude_at_1"] = _logu(rng, 0.008, 0.022)
    return form


def _first_point(rng):
    up = _sign(rng) * _logu(rng, 0.006, 0.025)
    if rng.random() < 0.5:
        down = up * _logu(rng, 0.3, 1.5)                 # same sign: a mount that always overshoots
    else:
        down = -up * _logu(rng, 0.3, 1.5)                # direction-antisymmetric (stick-slip lag)
    law = _choice(rng, ["stick_slip", "saturating", "power", "threshold"])
    return {
        "amp_up_frac_at_1": float(up), "amp_down_frac_at_1": float(down),
        "size_law": law,
        "v0_V": _logu(rng, 0.005, 0.05) if law == "stick_slip" else _logu(rng, 0.1, 2.0),
        "power": float(rng.uniform(0.3, 1.2)),
        "threshold_V": _logu(rng, 0.05, 1.0), "threshold_width_V": _logu(rng, 0.02, 0.3),
        "linger": int(rng.integers(0, 4)), "linger_ratio": float(rng.uniform(-0.5, 0.6)),
    }


def _backlash(rng):
    kind = _choice(rng, ["single", "distributed"])
    n = 1 if kind == "single" else int(rng.integers(3, 7))
    widths = sorted(rng.uniform(0.1, 1.0, n).tolist())
    weights = rng.dirichlet(np.ones(n)).tolist()
    return {"kind": kind, "widths_rel": widths, "weights": weights,
            "half_play_frac_at_1": _logu(rng, 0.004, 0.015),
            "asymmetry": float(rng.uniform(-0.5, 0.5)),
            "initial_side": int(rng.integers(-1, 2))}


# ---------------------------------------------------------------------------------------------- sensor
def _sensor_nonlinearity(rng):
    kind = _choice(rng, ["quadrant", "lateral_edge", "lever_tan", "sheet_gradient"])
    return {"kind": kind, "sign": _sign(rng), "zero_offset": float(rng.uniform(-0.8, 0.8)),
            "peak_frac_at_1": _logu(rng, 0.006, 0.02)}


def _drift_components(rng, pool, per_run_warmup: bool):
    comps = []
    k = int(rng.integers(1, 4))
    for name in rng.choice(pool, size=k, replace=False).tolist():
        w = float(rng.uniform(0.3, 1.0))
        if name == "warmup":
            comps.append({"kind": "warmup", "weight": w, "tau_s": _logu(rng, 300.0, 3600.0), "sign": _sign(rng),
                          "per_run": bool(per_run_warmup)})
        elif name == "log_settling":
            comps.append({"kind": "log_settling", "weight": w, "tau_s": _logu(rng, 30.0, 1800.0), "sign": _sign(rng)})
        elif name == "ou":
            comps.append({"kind": "ou", "weight": w, "tau_s": _logu(rng, 300.0, 10800.0)})
        elif name == "flicker":
            comps.append({"kind": "flicker", "weight": w, "alpha": float(rng.uniform(1.0, 2.0))})
        elif name == "trend":
            comps.append({"kind": "trend", "weight": w, "sign": _sign(rng), "curvature": float(rng.uniform(-0.5, 0.5))})
        elif name == "mode_hops":
            comps.append({"kind": "mode_hops", "weight": w, "rate_per_h": _logu(rng, 0.3, 3.0),
                          "smoothing_s": _logu(rng, 10.0, 300.0)})
        elif name == "tec_cycle":
            comps.append({"kind": "tec_cycle", "weight": w, "period_s": _logu(rng, 180.0, 1800.0)})
    return comps


def _baseline_drift(rng):
    comps = _drift_components(rng, ["warmup", "log_settling", "ou", "flicker", "trend"], per_run_warmup=True)
    return {"components": comps, "peak_frac_at_1": _logu(rng, 0.008, 0.025)}


def _gain_drift(rng):
    comps = _drift_components(rng, ["warmup", "ou", "flicker", "trend", "mode_hops", "tec_cycle"], per_run_warmup=False)
    return {"components": comps, "peak_rel_at_1": _logu(rng, 0.008, 0.025),
            "zero_offset": float(rng.uniform(-1.0, 1.0))}


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power, "sensor_nonlinearity": _sensor_nonlinearity,
    "reversible": _reversible, "interaction": _interaction, "first_point": _first_point,
    "gain_drift": _gain_drift, "backlash": _backlash, "accommodation": _accommodation,
    "heater_aging": _heater_aging,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of mechanism ``family`` (JSON-safe).  Independent of strength and of other mechanisms."""
    try:
        fn = _DRAW[family]
    except KeyError:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}") from None
    form = fn(rng)
    form["family"] = family
    return form
