"""The mechanisms' names and the random draw of each mechanism's *form*.

A form is a JSON-safe dict: the kernel, shape, time scales, signs and
asymmetries of one mechanism on one device, together with its size at
strength 1 (a fraction of the device's output swing, or a temperature).  It
never depends on the strength, on the seed of a session, or on the other
mechanisms present: the realisation (a drift's path) is drawn at simulation
time from the session seed.

The physics of every family is described in ``README.md``; the comments here
give the ranges.
"""

from __future__ import annotations

import numpy as np

from .paths import draw_path_form

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)

#: ``nucleation_kinetics`` is this generator's own outside mechanism (README.md).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "nucleation_kinetics")


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _pick(rng: np.random.Generator, options, p=None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> float:
    return 1.0 if rng.uniform() < p_plus else -1.0


# ---------------------------------------------------------------- temperature


def _thermal_lag(rng: np.random.Generator) -> dict:
    """Slow heat paths (substrate, package, mount) and the heater's own temperature coefficient."""
    kind = _pick(rng, ["single", "foster", "diffusive", "tcr", "tcr_only"], p=[0.2, 0.25, 0.25, 0.2, 0.1])
    paths: list[dict] = []
    if kind in ("single", "tcr"):
        paths = [{"weight": 1.0, "tau_s": _logu(rng, 3.0, 300.0)}]
    elif kind == "foster":
        n = int(rng.integers(2, 4))
        w = rng.dirichlet(np.ones(n))
        paths = [{"weight": float(wi), "tau_s": _logu(rng, 2.0, 600.0)} for wi in w]
    elif kind == "diffusive":
        taus = np.geomspace(_logu(rng, 1.0, 5.0), _logu(rng, 120.0, 900.0), 6)
        w = taus ** -0.5
        w = w / w.sum()
        paths = [{"weight": float(wi), "tau_s": float(ti)} for wi, ti in zip(w, taus)]
    tcr = None
    if kind in ("tcr", "tcr_only"):
        # relative drop of the heater power at full power once the package has warmed up
        tcr = {"power_drop": _u(rng, 0.005, 0.015), "tau_s": _logu(rng, 20.0, 600.0)}
    return {
        "kind": kind,
        "paths": paths,
        "lag_fraction": _u(rng, 0.006, 0.02) if paths else 0.0,  # of the steady rise, at strength 1
        "tcr": tcr,
    }


def _ambient_drift(rng: np.random.Generator) -> dict:
    return {
        "path": draw_path_form(rng),
        "rms_K": _u(rng, 0.05, 0.15),  # rms excursion of the ambient at strength 1 (K)
        # the beam's own bimorph response to the ambient, as a fraction of the heater's thermal term per kelvin
        "bimorph": _u(rng, 0.2, 1.0) if rng.uniform() < 0.5 else 0.0,
    }


# ---------------------------------------------------------------- film


def _interaction(rng: np.random.Generator) -> dict:
    return {
        "kernel": _pick(rng, ["linear", "tanh", "softcubic"]),
        "sharpness": _u(rng, 1.0, 2.5),
        # -1: the transformation stress opposes further transformation (broadens the loop)
        "sign": _sign(rng, p_plus=0.4),
        "loop_gain": _u(rng, 0.03, 0.08),  # at strength 1, relative to the steepest point of the major loop
    }


def _accommodation(rng: np.random.Generator) -> dict:
    return {
        "pattern": _pick(rng, ["uniform", "width", "centre", "tails"]),
        "direction": _sign(rng, p_plus=0.4),  # +1 training (grows), -1 fatigue (shrinks)
        "law": _pick(rng, ["exp", "log", "power"]),
        "cycles_scale": _logu(rng, 1.0, 8.0),
        "exponent": _u(rng, 0.3, 1.0),
        "prior_cycles": _u(rng, 0.0, 2.0),
        "anchor": _pick(rng, ["insulating", "symmetric", "metallic"], p=[0.5, 0.25, 0.25]),
        "frac": _u(rng, 0.015, 0.04),  # relative weight change after ten cycles at strength 1
    }


def _nucleation_kinetics(rng: np.random.Generator) -> dict:
    return {
        "kernel": _pick(rng, ["log", "power", "stretched"]),
        "tau0_s": _logu(rng, 0.1, 5.0),
        "exponent": _u(rng, 0.2, 0.5),
        "tau_s": _logu(rng, 10.0, 200.0),
        "beta": _u(rng, 0.3, 0.8),
        "cooling_over_heating": _logu(rng, 1.0 / 3.0, 3.0),
        "shift_K": _u(rng, 0.1, 0.3),  # kinetic shift after a 60 s hold at strength 1 (K)
    }


# ---------------------------------------------------------------- deflection


def _joule_power(rng: np.random.Generator) -> dict:
    shape = _pick(rng, ["power", "power_tc", "power_soft"])
    gamma = _u(rng, -0.5, 1.5) if shape == "power_tc" else (_u(rng, 0.5, 3.0) if shape == "power_soft" else 0.0)
    return {"shape": shape, "gamma": gamma, "frac": _u(rng, 0.01, 0.025)}


def _reversible(rng: np.random.Generator) -> dict:
    return {
        "shape": _pick(rng, ["sigmoid", "bump", "power", "onset"]),
        "variable": _pick(rng, ["film", "heater"], p=[0.7, 0.3]),
        "centre_offset_K": _u(rng, -12.0, 8.0),  # from the middle of the transition
        "width_K": _u(rng, 3.0, 12.0),
        "exponent": _u(rng, 2.0, 4.0),
        "sign": _sign(rng),
        "frac": _u(rng, 0.01, 0.025),
    }


def _creep(rng: np.random.Generator) -> dict:
    spectrum = _pick(rng, ["log_uniform", "discrete", "lognormal"])
    if spectrum == "log_uniform":
        taus = np.geomspace(_logu(rng, 1.0, 30.0), _logu(rng, 1800.0, 14400.0), 7)
        w = taus ** _u(rng, -0.5, 0.3)
    elif spectrum == "discrete":
        n = int(rng.integers(1, 4))
        taus = np.sort(np.array([_logu(rng, 2.0, 14400.0) for _ in range(n)]))
        w = rng.dirichlet(np.ones(n))
    else:
        centre = np.log10(_logu(rng, 30.0, 3600.0))
        width = _u(rng, 0.3, 1.2)
        lt = np.linspace(centre - 2.0 * width, centre + 2.0 * width, 9)
        taus = 10.0 ** lt
        w = np.exp(-0.5 * ((lt - centre) / width) ** 2)
    w = w / w.sum()
    return {
        "spectrum": spectrum,
        "tau_s": [float(t) for t in taus],
        "weights": [float(x) for x in w],
        "total": _u(rng, 0.015, 0.04),  # unrelaxed fraction of a change at strength 1
        "sign": _pick(rng, ["lag", "overshoot"], p=[0.7, 0.3]),
        "source": _pick(rng, ["total", "phase"]),
        "size_exponent": 1.0 if rng.uniform() < 0.4 else _u(rng, 0.6, 1.4),
        "asymmetry": 0.0 if rng.uniform() < 0.5 else _u(rng, -0.5, 0.5),
    }


def _first_point(rng: np.random.Generator) -> dict:
    weak = _u(rng, 0.2, 1.0)
    peak_weaker = rng.uniform() < 0.5
    return {
        "mode": _pick(rng, ["continue", "rebound"]),
        "frac": _u(rng, 0.01, 0.025),
        "after_peak": weak if peak_weaker else 1.0,  # reversal from heating to cooling
        "after_valley": 1.0 if peak_weaker else weak,  # reversal from cooling to heating
        "size_law": _pick(rng, ["const", "linear", "sqrt", "saturating"]),
        "size_scale_V": _logu(rng, 0.1, 2.0),
        "linger": 0.0 if rng.uniform() < 0.5 else _u(rng, 0.2, 0.6),
    }


def _backlash(rng: np.random.Generator) -> dict:
    return {
        "frac": _u(rng, 0.008, 0.02),  # half-width of the play at strength 1
        "asymmetry": _u(rng, -0.5, 0.5),
        "follow": 0.0 if rng.uniform() < 0.5 else _u(rng, 0.05, 0.3),
        "start": _u(rng, -1.0, 1.0),
    }


# ---------------------------------------------------------------- sensor


def _sensor_nonlinearity(rng: np.random.Generator) -> dict:
    shape = _pick(rng, ["tanh", "arctan", "erf", "cubic", "exp"])
    return {
        "shape": shape,
        "asymmetry": _sign(rng) * _u(rng, 0.5, 2.0) if shape == "exp" else 0.0,
        "centre": _u(rng, -0.8, 0.8),  # the PSD's centre within the output range (-1..1)
        "span": _u(rng, 0.4, 0.9),  # half the output range in units of the PSD's nonlinearity scale
        "frac": _u(rng, 0.01, 0.025),
    }


def _baseline_drift(rng: np.random.Generator) -> dict:
    return {"path": draw_path_form(rng), "rms_frac": _u(rng, 0.004, 0.01)}


def _gain_drift(rng: np.random.Generator) -> dict:
    return {"path": draw_path_form(rng), "rms_frac": _u(rng, 0.004, 0.01)}


_DRAW = {
    "thermal_lag": _thermal_lag,
    "creep": _creep,
    "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift,
    "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor_nonlinearity,
    "reversible": _reversible,
    "interaction": _interaction,
    "first_point": _first_point,
    "gain_drift": _gain_drift,
    "backlash": _backlash,
    "accommodation": _accommodation,
    "nucleation_kinetics": _nucleation_kinetics,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe): kernel, shape, time scales, signs...

    Does not depend on the strength, nor on other mechanisms present.
    """
    try:
        draw = _DRAW[family]
    except KeyError:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}") from None
    return {"family": family, **draw(rng)}
