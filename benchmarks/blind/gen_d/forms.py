"""The families of forms each mechanism is drawn from (``draw_form``).

A form is JSON-safe (str, float, int, lists, dicts) and never depends on the
strength, on the device, or on the other mechanisms present: device-dependent
scales (the phase swing, the transition's width) are applied when simulating.
See README.md for the physics behind each family and its ranges.
"""

from __future__ import annotations

import numpy as np

from . import drift

LIBRARY = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE = ("backlash", "accommodation", "psd_reflectance")


def _loguniform(rng: np.random.Generator, lo: float, hi: float, size=None):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> float:
    return 1.0 if rng.random() < p_plus else -1.0


def _gain(rng: np.random.Generator) -> float:
    """How strong strength 1 is for this form, around the nominal 1 % of the swing."""
    return float(rng.uniform(0.6, 1.5))


def _thermal_lag(rng):
    n = int(rng.integers(1, 4))
    taus = np.sort(_loguniform(rng, 5.0, 1800.0, n))
    form = {
        "taus_s": [float(x) for x in taus],
        "weights": [float(x) for x in rng.dirichlet(np.full(n, 1.2))],
        # Relative change of each path's time constant per 100 K of its own rise:
        # the heat capacity of Si / SiO2 rises and silicon's conductivity falls with T (> 0),
        # radiation and convection in the package grow with T (< 0).
        "tau_tempco_per_100K": float(rng.uniform(-0.3, 0.8)),
        "tcr": None,
        "gain": _gain(rng),
    }
    if rng.random() < 0.3:
        # Voltage-driven heater with a positive TCR: as the package warms its resistance rises
        # and its power falls, so the film first overshoots and then settles.
        form["tcr"] = {"tau_s": float(_loguniform(rng, 20.0, 900.0)), "relative": float(rng.uniform(0.2, 0.7))}
    return form


def _creep(rng):
    kernel = str(rng.choice(["prony", "log", "stretched", "power"]))
    k: dict = {"kind": kernel}
    if kernel == "prony":
        n = int(rng.integers(1, 5))
        k["taus_s"] = [float(x) for x in np.sort(_loguniform(rng, 3.0, 10_800.0, n))]
        k["weights"] = [float(x) for x in rng.dirichlet(np.ones(n))]
    elif kernel == "log":
        k["tau0_s"] = float(_loguniform(rng, 0.5, 60.0))
    elif kernel == "stretched":
        k["tau_s"] = float(_loguniform(rng, 30.0, 5400.0))
        k["beta"] = float(rng.uniform(0.3, 0.8))
    else:
        k["tau_s"] = float(_loguniform(rng, 1.0, 300.0))
        k["m"] = float(rng.uniform(0.15, 0.6))
    source = str(rng.choice(["total", "phase", "mixed", "thermal"]))
    w_phase, w_rest = {"total": (1.0, 1.0), "phase": (1.0, 0.0),
                       "mixed": (1.0, float(rng.uniform(0.0, 1.0))),
                       "thermal": (float(rng.uniform(0.0, 0.5)), 1.0)}[source]
    # How the relaxation rate depends on the size of the change: not at all, faster for big
    # changes (stress-activated flow), or slower for big changes (strain hardening).
    size = str(rng.choice(["linear", "activated", "saturating"]))
    return {
        "kernel": k,
        "source": source, "w_phase": w_phase, "w_rest": w_rest,
        # +1: the beam keeps going the way it moved (visco-elastic creep);
        # -1: it partly recovers (relaxation of the transformation strain).
        "sign": _sign(rng, 0.75),
        "asymmetry": float(rng.uniform(-0.6, 0.6)),
        "size": size, "size_saturation": float(rng.uniform(0.05, 0.5)),
        "gain": _gain(rng),
    }


def _joule_power(rng):
    return {
        # Expansion coefficient's relative change across the full rise (alpha(T) = alpha0 (1 + beta q)).
        "tempco": float(rng.uniform(-0.4, 1.0)),
        "gain": _gain(rng),
    }


def _sensor_nonlinearity(rng):
    return {
        "kind": str(rng.choice(["tanh", "rational", "sinh", "exp"])),
        # Where the PSD's linear centre sits within the device's output range (-1 .. 1).
        "centre": float(rng.uniform(-1.0, 1.0)),
        "sign": _sign(rng),  # for the asymmetric ("exp") kind: which side compresses
        "gain": _gain(rng),
    }


def _reversible(rng):
    return {
        "kind": str(rng.choice(["sigmoid", "bump", "power", "softplus"])),
        "input": str(rng.choice(["heater", "temperature"])),
        "sign": _sign(rng),
        "centre_offset_V": float(rng.uniform(-0.6, 0.6)),
        "width_V": float(rng.uniform(0.25, 1.2)),
        "power": float(rng.uniform(2.5, 6.0)),
        "gain": _gain(rng),
    }


def _interaction(rng):
    return {
        # +1: the transformation stress helps the transition along (steeper loops);
        # -1: it opposes it (sheared loops).
        "sign": _sign(rng, 0.6),
        "reference": str(rng.choice(["insulating", "mid"])),
        "gain": _gain(rng),
    }


def _first_point(rng):
    up = _sign(rng) * float(rng.uniform(0.5, 1.5))
    down = (np.sign(up) if rng.random() < 0.5 else _sign(rng)) * float(rng.uniform(0.5, 1.5))
    return {
        "amp_up": float(up), "amp_down": float(down),
        "size": str(rng.choice(["const", "linear", "saturating", "sqrt"])),
        "size_scale_V": float(rng.uniform(0.1, 1.0)),
        "linger_ratio": float(rng.uniform(0.0, 0.7)),
        "linger_points": int(rng.integers(1, 5)),
        "gain": _gain(rng),
    }


def _drift_form(rng, smoothing):
    form = drift.draw(rng, smoothing)
    form["gain"] = _gain(rng)
    return form


def _backlash(rng):
    return {
        "kind": str(rng.choice(["sharp", "distributed"])),
        "spread": float(rng.uniform(0.3, 0.9)),
        "asymmetry": float(rng.uniform(-0.4, 0.4)),
        "initial_side": int(rng.choice([-1, 0, 1])),
        "gain": _gain(rng),
    }


def _accommodation(rng):
    return {
        "count": str(rng.choice(["variation", "crossings"])),
        "law": str(rng.choice(["exp", "log", "power"])),
        "n0_cycles": float(_loguniform(rng, 1.0, 30.0)),
        "power": float(rng.uniform(0.3, 0.8)),
        "prior_cycles": float(rng.uniform(0.0, 10.0)),
        "shape": str(rng.choice(["amplitude", "sharpen", "shift", "width"])),
        "sign": _sign(rng),
        "gain": _gain(rng),
    }


def _psd_reflectance(rng):
    return {
        # Relative change of the film's reflectance at the laser's wavelength, insulating -> metallic.
        "contrast": _sign(rng, 0.6) * float(rng.uniform(0.1, 0.5)),
        # Shape of reflectance versus metallic fraction (effective medium, percolation): R ~ f**q.
        "fraction_power": float(rng.uniform(0.7, 2.5)),
        "gain": _gain(rng),
    }


_DRAW = {
    "thermal_lag": _thermal_lag,
    "creep": _creep,
    "baseline_drift": lambda rng: _drift_form(rng, (10.0, 300.0)),
    "ambient_drift": lambda rng: _drift_form(rng, (60.0, 900.0)),
    "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity,
    "reversible": _reversible,
    "interaction": _interaction,
    "first_point": _first_point,
    "gain_drift": lambda rng: _drift_form(rng, (30.0, 600.0)),
    "backlash": _backlash,
    "accommodation": _accommodation,
    "psd_reflectance": _psd_reflectance,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe), independent of strength and of the others."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}")
    return _DRAW[family](rng)
