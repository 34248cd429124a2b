"""Random *forms* of every mechanism (JSON-safe dicts), drawn independently of the strength.

Each ``_draw_<family>`` picks a member of a broad family of physically plausible
laws (kernels, spectra of time constants, signs, asymmetries, saturation laws).
The strength never enters here: a form says *how* the effect looks, the strength
only how large it is (see ``engine.py``).  The ranges are documented in
``README.md``.
"""

from __future__ import annotations

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "surface_adsorption")


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> int:
    return 1 if rng.uniform() < p_plus else -1


def _floats(a) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=float).ravel()]


# ----------------------------------------------------------------------------------------------
# temperature layer


def _draw_thermal_lag(rng):
    kernel = str(rng.choice(["discrete", "diffusive"], p=[0.6, 0.4]))
    if kernel == "discrete":
        n = int(rng.choice([1, 2, 3], p=[0.4, 0.35, 0.25]))
        taus = np.sort([_logu(rng, 3.0, 900.0) for _ in range(n)])
        shares = rng.dirichlet(np.ones(n))
    else:  # heat diffusing into substrate and package: a Prony series of a spreading kernel
        lo, hi = _logu(rng, 1.0, 8.0), _logu(rng, 120.0, 1800.0)
        taus = np.geomspace(lo, hi, 8)
        p = float(rng.uniform(-0.6, 0.4))
        shares = taus ** p
        shares = shares / shares.sum()
    gamma = 0.0 if rng.uniform() < 0.4 else float(rng.uniform(0.1, 0.8))
    return {"kernel": kernel, "taus_s": _floats(taus), "shares": _floats(shares),
            "conductance_tc": gamma}


def _drift_components(rng, menu: dict[str, float]) -> dict:
    """Pick a non-empty subset of ``menu`` (name -> inclusion probability) with Dirichlet weights."""
    names = list(menu)
    chosen = [k for k in names if rng.uniform() < menu[k]]
    if not chosen:
        chosen = [names[int(rng.integers(len(names)))]]
    w = rng.dirichlet(np.ones(len(chosen)) * 1.5)
    return {k: float(x) for k, x in zip(chosen, w)}


def _draw_ambient_drift(rng):
    comps = _drift_components(rng, {"hvac": 0.5, "powerlaw": 0.6, "door": 0.3, "trend": 0.4})
    return {
        "components": comps,
        "hvac_period_s": float(rng.uniform(900.0, 3600.0)),
        "hvac_wave": str(rng.choice(["sine", "triangle", "sawtooth"])),
        "alpha": float(rng.uniform(1.5, 2.5)),
        "corner_s": _logu(rng, 300.0, 1800.0),
        "door_rate_per_h": float(rng.uniform(0.2, 2.0)),
        "door_recovery_s": _logu(rng, 300.0, 1500.0),
    }


# ----------------------------------------------------------------------------------------------
# film layer


def _draw_interaction(rng):
    return {
        "sign": _sign(rng, 0.6),
        "ref_frac": float(rng.uniform(-1.0, 1.0)),
        "law": str(rng.choice(["linear", "saturating"], p=[0.55, 0.45])),
        "sat_scale": float(rng.uniform(0.5, 2.0)),
    }


def _draw_accommodation(rng):
    names = ["amplitude", "shift", "width", "spread"]
    k = int(rng.integers(1, 4))
    chosen = rng.choice(names, size=k, replace=False)
    mags = rng.dirichlet(np.ones(k))
    pattern = {str(c): float(_sign(rng) * m) for c, m in zip(chosen, mags)}
    law = str(rng.choice(["saturating", "log", "power"]))
    return {
        "pattern": pattern,
        "law": law,
        "cycles_scale": _logu(rng, 1.0, 20.0),
        "exponent": float(rng.uniform(0.3, 1.0)),
    }


# ----------------------------------------------------------------------------------------------
# deflection layer


def _draw_joule_power(rng):
    law = str(rng.choice(["integral_alpha", "power_exponent"], p=[0.65, 0.35]))
    return {
        "law": law,
        "tcr_compression": float(rng.uniform(0.0, 0.5)),
        "alpha_tc": float(rng.uniform(-0.5, 1.5)),
        "exponent": float(rng.uniform(1.6, 2.4)),
    }


def _draw_reversible(rng):
    shape = str(rng.choice(["sigmoid", "skew_sigmoid", "bump", "power", "legendre"]))
    return {
        "shape": shape,
        "sign": _sign(rng),
        "centre_rel": float(rng.uniform(-0.75, 0.75)),
        "width_V": float(rng.uniform(0.15, 1.0) if shape != "bump" else rng.uniform(0.3, 1.5)),
        "skew": _logu(rng, 0.3, 3.0),
        "exponent": float(rng.uniform(2.0, 5.0)),
        "coeffs": _floats(rng.normal(size=4) / np.arange(1, 5)),
    }


def _draw_creep(rng):
    kernel = str(rng.choice(["discrete", "lognormal", "powerlaw"]))
    if kernel == "discrete":
        n = int(rng.integers(1, 4))
        taus = np.sort([_logu(rng, 2.0, 20_000.0) for _ in range(n)])
        w = rng.dirichlet(np.ones(n))
    elif kernel == "lognormal":
        centre, sig = _logu(rng, 10.0, 5000.0), float(rng.uniform(0.3, 1.2))
        z = np.linspace(-2.0, 2.0, 9)
        taus = centre * 10.0 ** (sig * z)
        w = np.exp(-0.5 * z ** 2)
        w = w / w.sum()
    else:  # power law spectrum (q = 0: logarithmic creep, equal weight per decade)
        lo, hi = _logu(rng, 1.0, 10.0), _logu(rng, 2000.0, 20_000.0)
        taus = np.geomspace(lo, hi, 10)
        q = float(rng.uniform(-0.2, 0.8))
        w = taus ** (-q)
        w = w / w.sum()
    lr = float(rng.uniform(-1.2, 1.2))
    return {
        "kernel": kernel, "taus_s": _floats(taus), "weights": _floats(w),
        "sign": _sign(rng, 0.7),
        "thermal_mix": 0.0 if rng.uniform() < 0.5 else float(rng.uniform(0.0, 1.0)),
        "size_exponent": float(rng.uniform(0.6, 1.6)),
        "rate_up": float(np.exp(lr / 2)), "rate_down": float(np.exp(-lr / 2)),
    }


def _draw_surface_adsorption(rng):
    return {
        "theta_ambient": float(rng.uniform(0.3, 0.8)),
        "heat_kJ_mol": float(rng.uniform(35.0, 60.0)),
        "tau_ambient_s": _logu(rng, 60.0, 2400.0),
        "activation_kJ_mol": float(rng.uniform(25.0, 70.0)),
        "sign": _sign(rng),
    }


# ----------------------------------------------------------------------------------------------
# mount


def _draw_backlash(rng):
    kind = str(rng.choice(["play", "distributed", "soft"]))
    n = int(rng.integers(3, 7)) if kind == "distributed" else 1
    fr = np.sort(rng.uniform(0.15, 1.0, size=n))
    w = rng.dirichlet(np.ones(n))
    return {
        "kind": kind,
        "width_fracs": _floats(fr / np.sum(w * fr)),  # normalised: the weighted mean width is 1
        "weights": _floats(w),
        "asym": _logu(rng, 0.5, 2.0),
        "takeup_frac": float(rng.uniform(0.3, 1.0)),
        "initial_side": int(rng.choice([-1, 0, 1])),
    }


# ----------------------------------------------------------------------------------------------
# sensor


def _draw_sensor_nonlinearity(rng):
    return {
        "law": str(rng.choice(["tanh", "arctan", "erf", "cubic", "barrel", "quadratic"])),
        "centre_offset": float(rng.uniform(-0.6, 0.6)),
        "range_ratio": float(rng.uniform(1.1, 3.0)),
        "cal_points": [float(rng.uniform(0.02, 0.3)), float(rng.uniform(0.7, 0.98))],
        "orientation": _sign(rng),
    }


def _draw_baseline_drift(rng):
    comps = _drift_components(rng, {"powerlaw": 0.6, "warmup": 0.4, "hvac": 0.4, "slips": 0.3,
                                    "trend": 0.3})
    return {
        "components": comps,
        "alpha": float(rng.uniform(1.0, 2.5)),
        "corner_s": _logu(rng, 60.0, 600.0),
        "warmup_tau_s": _logu(rng, 300.0, 5000.0),
        "warmup_sign": _sign(rng),
        "hvac_period_s": float(rng.uniform(600.0, 3600.0)),
        "hvac_wave": str(rng.choice(["sine", "triangle", "sawtooth"])),
        "slips_rate_per_h": float(rng.uniform(0.3, 3.0)),
        "slip_settle_s": _logu(rng, 10.0, 300.0),
    }


def _draw_gain_drift(rng):
    comps = _drift_components(rng, {"powerlaw": 0.6, "warmup": 0.5, "hvac": 0.3, "mode_hops": 0.3,
                                    "trend": 0.3})
    return {
        "components": comps,
        "alpha": float(rng.uniform(1.0, 2.5)),
        "corner_s": _logu(rng, 60.0, 900.0),
        "warmup_tau_s": _logu(rng, 300.0, 5000.0),
        "warmup_sign": _sign(rng, 0.7),
        "hvac_period_s": float(rng.uniform(600.0, 3600.0)),
        "hvac_wave": str(rng.choice(["sine", "triangle"])),
        "hops_rate_per_h": float(rng.uniform(0.2, 2.0)),
    }


def _draw_first_point(rng):
    magn_r, magn_f = rng.uniform(0.3, 1.0, size=2)
    return {
        "amp_rise": float(_sign(rng) * magn_r),
        "amp_fall": float(_sign(rng) * magn_f),
        "size_law": str(rng.choice(["constant", "power", "saturating", "output_step"])),
        "size_exponent": float(rng.uniform(0.3, 1.5)),
        "size_scale_V": _logu(rng, 0.1, 2.0),
        "linger_ratio": 0.0 if rng.uniform() < 0.4 else float(rng.uniform(0.1, 0.7)),
        "linger_points": int(rng.integers(1, 4)),
    }


_DRAWERS = {
    "thermal_lag": _draw_thermal_lag, "creep": _draw_creep, "baseline_drift": _draw_baseline_drift,
    "ambient_drift": _draw_ambient_drift, "joule_power": _draw_joule_power,
    "sensor_nonlinearity": _draw_sensor_nonlinearity, "reversible": _draw_reversible,
    "interaction": _draw_interaction, "first_point": _draw_first_point, "gain_drift": _draw_gain_drift,
    "backlash": _draw_backlash, "accommodation": _draw_accommodation,
    "surface_adsorption": _draw_surface_adsorption,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of mechanism ``family`` (JSON-safe); independent of strength and of other mechanisms."""
    try:
        drawer = _DRAWERS[family]
    except KeyError:
        raise ValueError(f"unknown mechanism family {family!r}") from None
    form = drawer(rng)
    form["family"] = family
    return form
