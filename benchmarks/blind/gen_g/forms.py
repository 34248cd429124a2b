"""Random forms of every mechanism (JSON-safe dicts); see README.md for the physics and ranges.

A form fixes the *shape* of a mechanism on a device (kernels, time scales, signs, asymmetries,
profiles); it never depends on the strength nor on the other mechanisms present.  The strength
multiplies a size whose unit is chosen so that strength 1 moves the reading by roughly 1 % of the
swing (``2 * phase_swing_um``) where the mechanism shows most.
"""

from __future__ import annotations

import numpy as np

from .kernels import draw_drift, draw_spectrum

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "nucleation_aftereffect")


def _logu(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _sign(rng):
    return 1.0 if rng.random() < 0.5 else -1.0


def _thermal_lag(rng):
    form = {
        # the slow heat paths (substrate, side-braze package, socket, air): 3 s to 15 min
        "paths": draw_spectrum(rng, 3.0, 900.0),
        "size": _logu(rng, 1.0, 4.0),
        # cooling is slower or faster than heating (convection is stronger when hot; the
        # package's contact to the socket is not symmetric)
        "cooling_factor": _logu(rng, 0.6, 1.8),
        # how much of the slow heat the beam's thermal-expansion term feels relative to the film
        "expansion_share": float(rng.uniform(0.3, 1.3)),
        "overshoot": None,
    }
    if rng.random() < 0.45:
        # the heater's trace warms slowly too: at constant voltage its resistance creeps up and the
        # power droops, so the film first overshoots (or, on cooling steps, undershoots) its steady state
        big = rng.random() < 0.3
        form["overshoot"] = {
            "tau_s": _logu(rng, 5.0, 400.0),
            "ratio": float(rng.uniform(1.1, 2.0) if big else rng.uniform(0.15, 0.7)),
        }
    return form


def _creep(rng):
    branches = []
    kind = str(rng.choice(["lag", "overshoot", "mixed"], p=[0.5, 0.25, 0.25]))
    if kind in ("lag", "overshoot"):
        branches.append({"sign": -1.0 if kind == "lag" else 1.0,
                         "spectrum": draw_spectrum(rng, 4.0, 10_800.0), "weight": 1.0})
    else:
        # fast stress relaxation of the transition strain (overshoot) and slow anelastic lag, or vice versa
        fast_sign = _sign(rng)
        branches.append({"sign": fast_sign, "spectrum": draw_spectrum(rng, 4.0, 200.0),
                         "weight": float(rng.uniform(0.4, 1.0))})
        branches.append({"sign": -fast_sign, "spectrum": draw_spectrum(rng, 300.0, 10_800.0),
                         "weight": float(rng.uniform(0.4, 1.0))})
    return {
        "kind": kind,
        "branches": branches,
        "size": float(rng.uniform(0.6, 2.0)),
        "driver": str(rng.choice(["deflection", "phase"])),
        "exponent": float(rng.uniform(0.6, 1.4)),
        "asymmetry": float(rng.uniform(-0.5, 0.5)),
    }


def _baseline_drift(rng):
    return {"components": draw_drift(rng, tau_lo=300.0, tau_hi=20_000.0, period_lo=600.0, period_hi=3600.0),
            "size": float(rng.uniform(0.6, 1.5))}


def _ambient_drift(rng):
    return {"components": draw_drift(rng, tau_lo=600.0, tau_hi=20_000.0, period_lo=900.0, period_hi=5400.0),
            "size": float(rng.uniform(0.6, 1.5)),
            # the package and socket filter the room's temperature
            "package_tau_s": _logu(rng, 60.0, 1800.0)}


def _gain_drift(rng):
    return {"components": draw_drift(rng, kinds=("ou", "flicker", "cycle", "ramp", "settle", "steps"),
                                     tau_lo=300.0, tau_hi=20_000.0, period_lo=600.0, period_hi=3600.0),
            "size": float(rng.uniform(0.6, 1.5))}


def _joule_power(rng):
    return {
        # power = v^2 / R_heater(T): the heater's TCR makes the rise a little sub-quadratic
        "exponent": float(rng.uniform(1.7, 2.05)),
        # the bimorph's expansion mismatch grows (or falls) with temperature
        "expansion_curvature": float(rng.uniform(-0.4, 0.8)),
        "size": float(rng.uniform(0.6, 1.5)),
    }


def _sensor_nonlinearity(rng):
    return {
        "profile": str(rng.choice(["edges", "edge_power", "tilt", "offcentre", "asym_edges"])),
        "centre": float(rng.uniform(-0.6, 0.6)),
        "power": float(rng.uniform(2.0, 6.0)),
        "tilt": float(_sign(rng) * rng.uniform(0.3, 1.0)),
        "asym": float(rng.uniform(-0.7, 0.7)),
        "size": float(rng.uniform(0.6, 1.5)),
    }


def _reversible(rng):
    return {
        "shape": str(rng.choice(["sigmoid", "bump", "power", "onset"])),
        "input": str(rng.choice(["heater", "film"])),
        "centre_V": float(rng.uniform(2.5, 5.8)),
        "width_V": _logu(rng, 0.2, 1.5),
        "power": float(rng.uniform(2.0, 6.0)),
        "scale_V": _logu(rng, 0.3, 1.5),
        "sign": _sign(rng),
        "size": float(rng.uniform(0.6, 1.5)),
    }


def _interaction(rng):
    return {
        "sign": _sign(rng),
        "size": float(rng.uniform(0.6, 1.5)),
        # the phase deflection (as a fraction of its half swing) at which the mean field vanishes:
        # the film's stress-free state lies somewhere between insulating (-1) and metallic (+1)
        "reference": float(rng.uniform(-1.0, 1.0)),
        "curvature": float(rng.uniform(-0.5, 0.5)),
    }


def _first_point(rng):
    amp_up = float(_sign(rng) * rng.uniform(0.5, 2.0))
    ratio = float(rng.uniform(0.2, 1.5)) * (-1.0 if rng.random() < 0.2 else 1.0)
    return {
        "origin": str(rng.choice(["mechanical", "sensor"])),
        "reference": str(rng.choice(["input", "output", "fixed"], p=[0.45, 0.35, 0.2])),
        "amp_up": amp_up,
        "amp_down": amp_up * ratio,
        "size_law": str(rng.choice(["constant", "linear", "saturating", "sqrt"])),
        "v0_V": _logu(rng, 0.05, 2.0),
        "linger": 0.0 if rng.random() < 0.4 else float(rng.uniform(0.1, 0.6)),
    }


def _backlash(rng):
    kind = str(rng.choice(["sharp", "distributed", "dahl"]))
    form = {"kind": kind, "size": float(rng.uniform(0.5, 1.5)), "asym": float(rng.uniform(-0.3, 0.3)),
            "init": int(rng.choice([-1, 0, 1]))}
    if kind == "distributed":
        n = int(rng.integers(2, 6))
        r = np.sort(rng.uniform(0.1, 1.6, size=n))
        form["widths"] = [float(x) for x in r / np.mean(r)]
        form["weights"] = [float(x) for x in rng.dirichlet(np.ones(n))]
    if kind == "dahl":
        form["sharpness"] = float(rng.uniform(1.0, 5.0))
    return form


def _accommodation(rng):
    active = rng.choice(["uniform", "narrowing", "shift"], size=int(rng.integers(1, 3)), replace=False)
    return {
        "counting": str(rng.choice(["per_grain", "global"])),
        "law": str(rng.choice(["exp", "log", "power"])),
        "n0": _logu(rng, 2.0, 60.0),
        "p": float(rng.uniform(0.3, 0.8)),
        "uniform": float(_sign(rng) * rng.uniform(0.5, 1.5)) if "uniform" in active else 0.0,
        "narrowing": float(_sign(rng) * rng.uniform(0.5, 1.5)) if "narrowing" in active else 0.0,
        "shift": float(_sign(rng) * rng.uniform(0.5, 1.5)) if "shift" in active else 0.0,
        "width_bias": float(rng.uniform(-1.0, 1.0)),
        "size": float(rng.uniform(0.7, 1.5)),
    }


def _nucleation_aftereffect(rng):
    return {
        "law": str(rng.choice(["log", "power", "stretched"])),
        "tau0_s": _logu(rng, 0.05, 5.0),
        "p": float(rng.uniform(0.1, 0.35)),
        "tau_s": _logu(rng, 5.0, 300.0),
        "beta": float(rng.uniform(0.3, 0.8)),
        "heat_cool_ratio": _logu(rng, 0.4, 2.5),
        "size": float(rng.uniform(0.6, 1.5)),
    }


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity, "reversible": _reversible,
    "interaction": _interaction, "first_point": _first_point, "gain_drift": _gain_drift,
    "backlash": _backlash, "accommodation": _accommodation,
    "nucleation_aftereffect": _nucleation_aftereffect,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of ``family`` (JSON-safe), independent of the strength and of other mechanisms."""
    try:
        draw = _DRAW[family]
    except KeyError:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}") from None
    return draw(rng)
