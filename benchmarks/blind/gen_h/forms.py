"""Random forms of every mechanism (JSON-safe dicts), drawn from broad families.

A form never depends on the strength nor on the other mechanisms present.  The realisation of
a form (a drift's path, a per-run amplitude) is drawn later, in ``simulate``, from the seed and
the mechanism's name.  See README.md for the physics and the ranges.
"""

from __future__ import annotations

import math

import numpy as np

from . import disturbances, thermal

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "optical_contrast")


def _logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _pick(rng, options):
    return str(options[int(rng.integers(len(options)))])


def _sign(rng, p_plus=0.5):
    return 1.0 if rng.random() < p_plus else -1.0


def _thermal_lag(rng):
    return thermal.draw(rng)


def _creep(rng):
    kernel = _pick(rng, ("prony", "kww", "power_law", "lognormal"))
    f: dict = {"kernel": kernel}
    if kernel == "prony":
        m = int(rng.integers(2, 5))
        f["taus_s"] = sorted(_logu(rng, 2.0, 14_400.0) for _ in range(m))
        f["weights"] = [float(w) for w in rng.dirichlet(np.ones(m))]
    elif kernel == "kww":
        f["tau_s"] = _logu(rng, 20.0, 10_800.0)
        f["beta"] = float(rng.uniform(0.25, 0.9))
    elif kernel == "power_law":
        f["t0_s"] = _logu(rng, 1.0, 30.0)
        f["n"] = float(rng.uniform(0.1, 0.6))
    else:
        f["tau_m_s"] = _logu(rng, 20.0, 5_000.0)
        f["sigma_ln"] = float(rng.uniform(0.5, 2.5))
    f["driver"] = _pick(rng, ("total", "phase"))
    f["norton_n"] = float(rng.uniform(0.7, 2.0)) if rng.random() < 0.65 else 1.0
    f["rho"] = _logu(rng, 1.0 / 3.0, 3.0) if rng.random() < 0.6 else 1.0
    f["asym"] = float(rng.uniform(-0.6, 0.6)) if rng.random() < 0.6 else 0.0
    f["sign"] = _sign(rng, 0.75)
    f["resid_frac"] = float(rng.uniform(0.006, 0.02))
    return f


def _drift(rng, kinds):
    f = disturbances.draw_process(rng, kinds)
    f["amp"] = float(rng.uniform(0.6, 1.5))
    return f


def _baseline_drift(rng):
    return _drift(rng, disturbances.PROCESSES)


def _gain_drift(rng):
    return _drift(rng, disturbances.PROCESSES)


def _ambient_drift(rng):
    f = _drift(rng, disturbances.PROCESSES)
    f["package_lag_s"] = _logu(rng, 30.0, 1_200.0) if rng.random() < 0.5 else 0.0
    return f


def _joule_power(rng):
    law = _pick(rng, ("constant", "linear", "kelvin_power", "transition_step", "saturating"))
    f: dict = {"alpha_law": law}
    if law == "linear":
        f["beta"] = float(rng.uniform(-0.6, 1.5))
    elif law == "kelvin_power":
        f["q"] = float(rng.uniform(-1.0, 2.5))
    elif law == "transition_step":
        f["step"] = float(rng.uniform(-0.5, 0.8))
        f["width_factor"] = float(rng.uniform(0.7, 2.0))
    elif law == "saturating":
        f["theta_s_K"] = _logu(rng, 20.0, 300.0)
    f["amp_frac"] = float(rng.uniform(0.006, 0.02))
    return f


def _sensor_nonlinearity(rng):
    shape = _pick(rng, ("tanh", "arctan", "erf", "algebraic", "exponential", "clipped_spot"))
    f: dict = {"shape": shape}
    if shape == "algebraic":
        f["q"] = float(rng.uniform(1.5, 4.0))
    elif shape == "exponential":
        f["a"] = _sign(rng)
    elif shape == "clipped_spot":
        f["spot_ratio"] = float(rng.uniform(0.2, 0.6))
    f["centre_frac"] = float(rng.uniform(-1.2, 1.2))
    f["amp_frac"] = float(rng.uniform(0.006, 0.02))
    return f


def _reversible(rng):
    shape = _pick(rng, ("sigmoid", "bump", "power", "legendre", "exponential"))
    f: dict = {"shape": shape, "arg": _pick(rng, ("heater", "temperature"))}
    if shape in ("sigmoid", "bump"):
        f["centre_offset_K"] = float(rng.uniform(-15.0, 15.0))
        f["width_K"] = _logu(rng, 3.0, 25.0)
    elif shape == "power":
        f["p"] = float(rng.uniform(1.5, 4.0))
    elif shape == "legendre":
        c = rng.standard_normal(3)
        f["coeffs"] = [float(x) for x in c]  # of P2, P3, P4
    else:
        f["scale"] = float(rng.uniform(0.15, 0.6))
    f["sign"] = _sign(rng)
    f["amp_frac"] = float(rng.uniform(0.01, 0.025))
    return f


def _interaction(rng):
    f = {
        "domain": _pick(rng, ("volts", "kelvin")),
        "reference": _pick(rng, ("insulating", "centre")),
        "law": _pick(rng, ("linear", "saturating", "quadratic")),
        "sign": _sign(rng, 0.6),
        "gain1": float(rng.uniform(0.03, 0.09)),
    }
    if f["law"] == "saturating":
        f["sat"] = float(rng.uniform(0.4, 1.5))
    elif f["law"] == "quadratic":
        f["a"] = float(rng.uniform(-0.2, 0.2))
    return f


def _first_point(rng):
    f = {
        "sense": _pick(rng, ("overshoot", "lag")),
        "size_law": _pick(rng, ("const", "linear", "sqrt", "saturating")),
        "driver": _pick(rng, ("input", "output")),
        "asym": float(rng.uniform(-1.0, 1.0)) if rng.random() < 0.6 else 0.0,
        "linger": _pick(rng, ("none", "geometric", "taper")),
        "rho": float(rng.uniform(0.2, 0.7)),
        "n_steps": int(rng.integers(1, 4)),
        "s0_V": _logu(rng, 0.05, 1.5),
        "amp_frac": float(rng.uniform(0.01, 0.03)),
    }
    return f


def _backlash(rng):
    kind = _pick(rng, ("play", "compliant_play", "prandtl_ishlinskii", "smooth_play"))
    f: dict = {"kind": kind}
    if kind == "compliant_play":
        f["follow"] = float(rng.uniform(0.1, 0.6))
    elif kind == "prandtl_ishlinskii":
        m = int(rng.integers(2, 6))
        f["radii"] = sorted(float(x) for x in rng.uniform(0.1, 1.0, m))
        f["weights"] = [float(w) for w in rng.dirichlet(np.ones(m))]
    elif kind == "smooth_play":
        f["take_up"] = float(rng.uniform(0.2, 1.0))
    f["r_frac"] = float(rng.uniform(0.005, 0.02))
    return f


def _accommodation(rng):
    f = {
        "pattern": _pick(rng, ("uniform", "shift", "broaden", "random_cells")),
        "law": _pick(rng, ("exponential", "logarithmic", "power", "linear")),
        "N0": _logu(rng, 2.0, 60.0),
        "p": float(rng.uniform(0.3, 1.0)),
        "N_pre": _logu(rng, 0.5, 200.0) if rng.random() < 0.7 else 0.0,
        "sign": _sign(rng),
        "shift_V": float(rng.uniform(0.05, 0.3)),
        "broaden": float(rng.uniform(0.05, 0.2)),
        "sigma": float(rng.uniform(0.3, 1.0)),
        "field_seed": int(rng.integers(0, 2**31 - 1)),
        "amp_frac": float(rng.uniform(0.01, 0.03)),
    }
    return f


def _optical_contrast(rng):
    f = {
        "law": _pick(rng, ("linear", "saturating", "percolation", "convex")),
        "m0": float(rng.uniform(0.1, 0.5)),
        "m_c": float(rng.uniform(0.3, 0.7)),
        "sharp": float(rng.uniform(0.05, 0.2)),
        "sign": _sign(rng, 0.65),
        "background_frac": float(rng.uniform(-1.5, 1.5)),
        "amp_frac": float(rng.uniform(0.01, 0.03)),
    }
    return f


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain_drift,
    "backlash": _backlash, "accommodation": _accommodation, "optical_contrast": _optical_contrast,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe); independent of the strength."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}")
    form = _DRAW[family](rng)
    form["family"] = family
    return form
