"""Random *forms* of every mechanism (kernels, laws, time scales, signs, asymmetries).

A form is a JSON-safe dict drawn from ``rng``; it never depends on the strength,
on the device or on the other mechanisms present.  The *realisation* of a form
(a drift's path, a run's random phase) is drawn later in ``simulate`` from the
session's seed.
"""

from __future__ import annotations

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "phase_reflectance")


def _u(rng, lo, hi) -> float:
    return float(rng.uniform(lo, hi))


def _logu(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _sign(rng, p_plus=0.5) -> int:
    return 1 if rng.uniform() < p_plus else -1


def _choice(rng, options, p=None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


# --------------------------------------------------------------------------- drift paths
def _drift_path(rng, kinds, tau_lo=600.0, tau_hi=10_800.0) -> dict:
    """A slow random path (unit scale); the realisation is drawn per run from the seed."""
    kind = _choice(rng, kinds)
    f: dict = {"kind": kind}
    if kind == "ou":  # Ornstein-Uhlenbeck wander (laser pointing, room air)
        f["tau_s"] = _logu(rng, tau_lo, tau_hi)
    elif kind == "random_walk":  # Brownian wander, optionally smoothed (settling of the mount)
        f["smooth_s"] = _logu(rng, 30.0, 900.0)
    elif kind == "warmup":  # exponential settling of the electronics / laser after power-on
        f["tau_s"] = _logu(rng, 600.0, 6000.0)
        f["residual"] = _u(rng, 0.0, 0.5)
        f["residual_tau_s"] = _logu(rng, 900.0, 7200.0)
    elif kind == "periodic":  # thermostat / HVAC cycling of the room
        f["period_s"] = _logu(rng, 900.0, 5400.0)
        f["wave"] = _choice(rng, ("sine", "triangle", "sawtooth"))
        f["trend"] = _u(rng, 0.0, 0.6)
    elif kind == "pink":  # 1/f-like: a sum of OU processes over a decade or two of time scales
        lo = _logu(rng, 60.0, 600.0)
        f["tau_lo_s"] = lo
        f["tau_hi_s"] = lo * _logu(rng, 10.0, 60.0)
        f["components"] = int(rng.integers(3, 7))
    elif kind == "steps":  # sudden slips (mount slip, laser mode hop) settling over tens of s to minutes
        f["mean_gap_s"] = _logu(rng, 1200.0, 5400.0)
        f["settle_s"] = _logu(rng, 20.0, 600.0)
        f["walk"] = _u(rng, 0.2, 0.7)
    return f


# --------------------------------------------------------------------------- library
def _thermal_lag(rng) -> dict:
    kernel = _choice(rng, ("exp_sum", "diffusive", "lognormal", "power_spectrum"))
    f: dict = {"kernel": kernel}
    if kernel == "exp_sum":  # one to three discrete slow paths (substrate, package, mount)
        n = int(rng.integers(1, 4))
        taus = sorted(_logu(rng, 4.0, 900.0) for _ in range(n))
        w = rng.dirichlet(np.ones(n))
        f["taus_s"] = [float(t) for t in taus]
        f["weights"] = [float(x) for x in w]
    elif kernel == "diffusive":  # heat diffusing into a thick substrate: 1 - c/sqrt(t) approach
        lo = _logu(rng, 2.0, 20.0)
        f["tau_lo_s"] = lo
        f["tau_hi_s"] = lo * _logu(rng, 30.0, 500.0)
        f["exponent"] = 0.5
    elif kernel == "power_spectrum":  # a spectrum of paths with weights ~ tau^-b per decade
        lo = _logu(rng, 2.0, 30.0)
        f["tau_lo_s"] = lo
        f["tau_hi_s"] = lo * _logu(rng, 10.0, 300.0)
        f["exponent"] = _u(rng, -0.3, 0.9)
    else:  # lognormal spread around one time scale
        f["tau_c_s"] = _logu(rng, 8.0, 400.0)
        f["sigma_ln"] = _u(rng, 0.3, 1.6)
    # heating vs cooling: convection/radiation make the slow path's time constant direction dependent
    f["cooling_ratio"] = _logu(rng, 0.5, 2.0) if rng.uniform() < 0.5 else 1.0
    # heater resistance follows the slow temperature (series current-limit resistor: sign either way)
    f["tcr"] = bool(rng.uniform() < 0.35)
    f["tcr_sign"] = _sign(rng)
    f["tcr_tau_s"] = _logu(rng, 10.0, 600.0)
    f["tcr_share"] = _u(rng, 0.2, 1.0)
    return f


def _creep(rng) -> dict:
    spectrum = _choice(rng, ("prony", "log_uniform", "power_law", "lognormal"))
    f: dict = {"spectrum": spectrum}
    if spectrum == "prony":
        n = int(rng.integers(2, 5))
        f["taus_s"] = sorted(_logu(rng, 2.0, 20_000.0) for _ in range(n))
        f["weights"] = [float(x) for x in rng.dirichlet(np.ones(n))]
    elif spectrum == "lognormal":
        f["tau_c_s"] = _logu(rng, 20.0, 5000.0)
        f["sigma_ln"] = _u(rng, 0.5, 2.5)
    else:
        f["tau_lo_s"] = _logu(rng, 1.0, 30.0)
        f["tau_hi_s"] = _logu(rng, 1800.0, 30_000.0)
        f["exponent"] = _u(rng, -0.4, 0.6) if spectrum == "power_law" else 0.0
    # -1: the beam keeps moving the way it went (reading short of the new shape);
    # +1: anelastic overshoot that relaxes back (stress relaxation of the transition strain)
    f["sign"] = -1 if rng.uniform() < 0.7 else 1
    f["driver"] = _choice(rng, ("total", "phase"), p=(0.6, 0.4))
    law = _choice(rng, ("linear", "power", "saturating"))
    f["size_law"] = law
    f["size_exponent"] = _u(rng, 0.6, 1.5) if law == "power" else 1.0
    f["size_scale"] = _u(rng, 0.05, 0.5) if law == "saturating" else 1.0
    f["up_factor"], f["down_factor"] = 1.0, 1.0
    if rng.uniform() < 0.6:
        f["up_factor" if rng.uniform() < 0.5 else "down_factor"] = _u(rng, 0.25, 1.0)
    return f


def _baseline_drift(rng) -> dict:
    return {"path": _drift_path(rng, ("ou", "random_walk", "warmup", "periodic", "pink", "steps"))}


def _ambient_drift(rng) -> dict:
    return {
        "path": _drift_path(rng, ("ou", "random_walk", "warmup", "periodic", "pink"), 1200.0, 14_400.0),
        # the bimorph also bends a little with the room temperature (share of a secant slope)
        "bimorph_share": _u(rng, 0.0, 0.6) if rng.uniform() < 0.5 else 0.0,
        # the film sits closer to the package than the beam's root: lag of the film behind the room
        "film_lag_s": _logu(rng, 30.0, 900.0),
    }


def _joule_power(rng) -> dict:
    law = _choice(rng, ("square", "power", "tempco"))
    f: dict = {"law": law, "anchor_frac": _u(rng, 0.5, 1.0)}
    f["exponent"] = _u(rng, 1.5, 2.5) if law == "power" else 2.0
    # relative change of the expansion coefficient per kelvin (CTE of Si/SiO2/Au rises with T)
    f["cte_per_K"] = _u(rng, -0.003, 0.012) if law == "tempco" else 0.0
    return f


def _sensor_nonlinearity(rng) -> dict:
    shape = _choice(rng, ("tanh", "atan", "algebraic", "exp", "odd_even"))
    return {
        "shape": shape,
        "centre_frac": _u(rng, -0.7, 0.7),   # spot's zero relative to the middle of the swing
        "half_length_frac": _u(rng, 0.6, 1.6),  # PSD half-length relative to the swing
        "even_sign": _sign(rng),
        "even_share": _u(rng, 0.2, 0.8),
    }


def _reversible(rng) -> dict:
    shape = _choice(rng, ("sigmoid_T", "bump_T", "power_v", "square_T", "softplus_T"))
    return {
        "shape": shape,
        "sign": _sign(rng),
        "centre_C": _u(rng, 40.0, 95.0),
        "width_K": _logu(rng, 3.0, 25.0),
        "exponent": _u(rng, 1.5, 4.0),
    }


def _interaction(rng) -> dict:
    law = _choice(rng, ("linear", "saturating", "asymmetric", "metallic_only"))
    return {
        "law": law,
        "sign": _sign(rng),
        "saturation": _u(rng, 0.5, 2.5),
        "asymmetry": _u(rng, -0.8, 0.8),
    }


def _first_point(rng) -> dict:
    law = _choice(rng, ("constant", "linear", "sqrt", "saturating"))
    return {
        "size_law": law,
        "size_scale_V": _logu(rng, 0.05, 1.5),
        "polarity": _choice(rng, ("fixed", "along", "against")),
        "sign": _sign(rng),
        "up_factor": _u(rng, 0.3, 1.0) if rng.uniform() < 0.5 else 1.0,
        "down_factor": _u(rng, 0.3, 1.0) if rng.uniform() < 0.5 else 1.0,
        "linger": int(rng.integers(0, 4)),
        "decay": _u(rng, 0.15, 0.6),
        "first_step_counts": bool(rng.uniform() < 0.5),
    }


def _gain_drift(rng) -> dict:
    return {
        "path": _drift_path(rng, ("ou", "random_walk", "warmup", "periodic", "pink", "steps")),
        # the logger subtracts an electronic zero after the gain stage: the factor acts about it
        "zero_frac": _u(rng, -0.5, 0.5) if rng.uniform() < 0.5 else None,
    }


# --------------------------------------------------------------------------- outside
def _backlash(rng) -> dict:
    kind = _choice(rng, ("play", "partial", "asymmetric", "distributed"))
    f: dict = {"kind": kind, "coupling": 1.0, "asymmetry": 0.0, "plays": 1}
    if kind == "partial":  # the spot sees a mix of beam and mount motion
        f["coupling"] = _u(rng, 0.4, 1.0)
    elif kind == "asymmetric":  # more play on one side of the mount
        f["asymmetry"] = _u(rng, -0.8, 0.8)
    elif kind == "distributed":  # several contacts with different play (Prandtl-Ishlinskii like)
        f["plays"] = int(rng.integers(2, 6))
        f["spread"] = _u(rng, 0.3, 1.0)
    f["initial"] = _choice(rng, ("centred", "below", "above"))
    return f


def _accommodation(rng) -> dict:
    return {
        "pattern": _choice(rng, ("uniform", "narrowing", "shift", "patchy")),
        "pattern_seed": int(rng.integers(0, 2**31 - 1)),
        "sign": _sign(rng),
        "law": _choice(rng, ("exp", "log", "hyperbolic")),
        "n0_cycles": _logu(rng, 1.0, 30.0),
        "counting": _choice(rng, ("per_grain", "global")),
        "conserve": bool(rng.uniform() < 0.5),
    }


def _phase_reflectance(rng) -> dict:
    return {
        # relative change of the reflected 985 nm power from insulating to metallic VO2
        "contrast": _sign(rng, 0.6) * _u(rng, 0.1, 0.6),
        # share of the sum-channel offset (background light, dark current) vs difference-channel offset
        "sum_share": _u(rng, 0.4, 1.0),
        "diff_sign": _sign(rng),
        "centre_frac": _u(rng, -0.7, 0.7),
    }


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain_drift,
    "backlash": _backlash, "accommodation": _accommodation, "phase_reflectance": _phase_reflectance,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of mechanism ``family`` (JSON-safe); independent of the strength and of other mechanisms."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}; known: {sorted(_DRAW)}")
    form = _DRAW[family](rng)
    form["family"] = family
    return form
