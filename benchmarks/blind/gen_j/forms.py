"""Random *forms* of every mechanism (JSON-safe dicts), drawn independently of strength and of each other.

A form fixes the shape of a mechanism on one device (kernels, spectra of time
constants, signs, asymmetries, saturation laws, disturbance processes); the
strength (given separately to ``simulate``) only scales it, and the seed only
fixes a drift's realisation.
"""

from __future__ import annotations

import numpy as np

LIBRARY: tuple[str, ...] = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "metal_plasticity")


def _lu(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform draw in [lo, hi]."""
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> int:
    return 1 if rng.uniform() < p_plus else -1


def _choice(rng: np.random.Generator, options, p=None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


# ---------------------------------------------------------------- relaxation spectra
def _spectrum(rng: np.random.Generator, lo: float, hi: float, kinds, diffusive: bool = False) -> dict:
    """A spectrum of relaxation times between ``lo`` and ``hi`` seconds, from a broad family."""
    kind = _choice(rng, kinds)
    if kind == "discrete":
        n = int(rng.integers(1, 4))
        taus = sorted(_lu(rng, lo, hi) for _ in range(n))
        weights = rng.dirichlet(np.full(n, 1.5))
        return {"kind": kind, "taus_s": [float(t) for t in taus], "weights": [float(w) for w in weights]}
    if kind == "lognormal":
        return {"kind": kind, "centre_s": _lu(rng, lo * 3.0, hi / 3.0), "sigma_ln": _u(rng, 0.4, 2.0)}
    if kind == "power_law":
        # weights per log-interval ~ tau**-beta between tmin and tmax; beta = 1/2 is one-dimensional
        # diffusion into a thick substrate, beta = 0 logarithmic creep.
        beta = _u(rng, 0.3, 0.7) if diffusive else _u(rng, -0.3, 0.6)
        return {"kind": kind, "tmin_s": _lu(rng, lo, lo * 8.0), "tmax_s": _lu(rng, hi / 10.0, hi), "beta": beta}
    if kind == "stretched":
        return {"kind": kind, "tau_s": _lu(rng, lo * 5.0, hi / 3.0), "beta": _u(rng, 0.3, 0.9)}
    raise AssertionError(kind)


# ---------------------------------------------------------------- lab disturbance processes
_DRIFT_MENUS = {
    # PSD zero: laser pointing, settling of the lever's mount, electronics warm-up, 1/f electronics,
    # air-conditioning cycles moving the optics, sporadic slips of the mount.
    "baseline_drift": ("ou", "random_walk", "warmup", "flicker", "hvac", "slips"),
    # room / package temperature: thermostat cycling, the day's trend, the building's thermal mass,
    # doors opening, equipment in the room warming up.
    "ambient_drift": ("hvac", "diurnal", "ou", "doors", "warmup"),
    # PSD sensitivity: laser power / spot profile warm-up, slow wander, the lever's temperature,
    # laser mode hops (random telegraph), slow random walk of the alignment.
    "gain_drift": ("warmup", "ou", "hvac", "mode_hops", "random_walk"),
}


def _drift_component(kind: str, family: str, rng: np.random.Generator) -> dict:
    if kind == "ou":
        lo, hi = (1200.0, 10_800.0) if family == "ambient_drift" else (600.0, 7200.0)
        return {"kind": kind, "tau_s": _lu(rng, lo, hi), "stationary_start": bool(rng.uniform() < 0.6)}
    if kind == "random_walk":
        return {"kind": kind}
    if kind == "warmup":
        # how far the warm-up has gone when a run starts, in units of its time constant
        return {"kind": kind, "tau_s": _lu(rng, 600.0, 7200.0), "sign": _sign(rng),
                "since_on_tau": _u(rng, 0.0, 1.2)}
    if kind == "flicker":
        return {"kind": kind, "alpha": _u(rng, 0.8, 2.0)}
    if kind == "hvac":
        lo, hi = (480.0, 3600.0) if family == "ambient_drift" else (600.0, 3000.0)
        return {"kind": kind, "period_s": _lu(rng, lo, hi), "shape": _choice(rng, ("sine", "triangle", "sawtooth")),
                "duty": _u(rng, 0.15, 0.85), "jitter": _u(rng, 0.02, 0.15)}
    if kind == "diurnal":
        return {"kind": kind, "period_s": _u(rng, 0.8, 1.2) * 86_400.0}
    if kind == "doors":
        return {"kind": kind, "rate_per_h": _lu(rng, 0.2, 1.5), "recover_s": _lu(rng, 300.0, 1800.0),
                "onset_s": _lu(rng, 20.0, 120.0)}
    if kind == "slips":
        return {"kind": kind, "rate_per_h": _lu(rng, 0.2, 2.0), "settle_s": _lu(rng, 5.0, 120.0)}
    if kind == "mode_hops":
        return {"kind": kind, "mean_dwell_s": _lu(rng, 600.0, 5400.0), "levels": int(rng.integers(2, 4))}
    raise AssertionError(kind)


def _drift_form(family: str, rng: np.random.Generator) -> dict:
    menu = _DRIFT_MENUS[family]
    n = int(rng.choice([1, 2, 3], p=[0.45, 0.35, 0.20]))
    kinds = [menu[i] for i in rng.choice(len(menu), size=n, replace=False)]
    weights = rng.dirichlet(np.full(n, 1.5))
    comps = []
    for kind, w in zip(kinds, weights):
        comp = _drift_component(kind, family, rng)
        comp["weight"] = float(w)
        comps.append(comp)
    return {"components": comps}


# ---------------------------------------------------------------- mechanisms
def _thermal_lag(rng):
    return {
        "spectrum": _spectrum(rng, 2.0, 3000.0, ("discrete", "lognormal", "power_law"), diffusive=True),
        # slow paths speed up (or slow down) at high temperature: convection, radiation, the
        # substrate's conductivity falling with temperature.
        "conductance_T": _u(rng, -0.3, 0.6),
        # the leads and package warm slowly, their resistance rises, the heater's share of the
        # (constant) voltage sags: an overshoot after every step up (undershoot after steps down).
        "tcr": bool(rng.uniform() < 0.35),
        "tcr_rel": _u(rng, 0.2, 1.0),
        "tcr_tau_s": _lu(rng, 5.0, 300.0),
    }


def _creep(rng):
    return {
        "spectrum": _spectrum(rng, 2.0, 20_000.0, ("discrete", "lognormal", "power_law", "stretched")),
        "sign": _sign(rng, 0.6),  # +1: anelastic lag (approaches the new shape); -1: overshoot, relaxes back
        # the relaxed shape is a nonlinear function of the drive: the creep after a change depends on its size
        "target_law": _choice(rng, ("linear", "quadratic", "saturating")),
        "curvature": _u(rng, -0.6, 0.6),
        "sat_scale": _u(rng, 0.3, 1.0),
        # relaxation faster when the relaxed strain grows than when it shrinks (or the reverse)
        "asymmetry": _u(rng, -0.6, 0.6),
        "source": _choice(rng, ("output", "phase", "mixed")),
        "mix": _u(rng, 0.2, 0.8),
    }


def _joule_power(rng):
    law = _choice(rng, ("constant", "linear", "saturating", "activated", "step"))
    form = {"alpha_law": law}
    if law == "linear":
        form["b"] = _u(rng, -0.6, 1.5)
    elif law == "saturating":
        form["r_s"] = _lu(rng, 0.2, 3.0)
    elif law == "activated":
        form["r_a"] = _lu(rng, 0.3, 3.0)
    elif law == "step":
        form.update(ratio=_lu(rng, 0.4, 2.5), r_k=_u(rng, 0.2, 0.9), width=_u(rng, 0.02, 0.15))
    return form


def _sensor(rng):
    shape = _choice(rng, ("tanh", "erf", "sinh", "exp_bow", "rational"))
    return {"shape": shape, "centre": _u(rng, -1.2, 1.2), "bow_sign": _sign(rng)}


def _reversible(rng):
    kind = _choice(rng, ("precursor_sigmoid", "bump", "polynomial", "arrhenius", "saturating"))
    form = {"kind": kind, "sign": _sign(rng)}
    if kind == "precursor_sigmoid":
        form.update(offset_K=_u(rng, -12.0, 12.0), width_K=_lu(rng, 4.0, 30.0))
    elif kind == "bump":
        form.update(offset_K=_u(rng, -15.0, 15.0), width_K=_lu(rng, 3.0, 20.0))
    elif kind == "polynomial":
        form.update(variable=_choice(rng, ("voltage", "temperature")),
                    coefficients=[float(c) for c in rng.normal(size=3)])
    elif kind == "arrhenius":
        form.update(scale_K=_lu(rng, 5.0, 40.0))
    elif kind == "saturating":
        form.update(r0=_lu(rng, 0.05, 0.8))
    return form


def _interaction(rng):
    law = _choice(rng, ("linear", "saturating", "superlinear"))
    return {"sign": _sign(rng), "law": law, "law_param": _u(rng, 0.5, 2.0) if law == "saturating" else _u(rng, 0.2, 1.0),
            "reference": _choice(rng, ("insulating", "centre", "metallic"), p=[0.5, 0.3, 0.2])}


def _first_point(rng):
    direction = _choice(rng, ("same", "travel", "asymmetric", "one_sided"))
    if direction == "same":
        a = _sign(rng) * _u(rng, 0.6, 1.0)
        amps = (a, a * _u(rng, 0.7, 1.0))
    elif direction == "travel":
        a = _sign(rng) * _u(rng, 0.6, 1.0)
        amps = (a, -a * _u(rng, 0.6, 1.0))
    elif direction == "asymmetric":
        amps = (_sign(rng) * _u(rng, 0.5, 1.0), _sign(rng) * _u(rng, 0.0, 0.6))
    else:
        amps = (_sign(rng) * _u(rng, 0.6, 1.0), 0.0)
    if rng.uniform() < 0.5:
        amps = amps[::-1]
    m = max(abs(amps[0]), abs(amps[1]))
    return {"direction": direction, "amp_up": float(amps[0] / m), "amp_down": float(amps[1] / m),
            "size_law": _choice(rng, ("constant", "linear", "sqrt", "saturating", "threshold")),
            "size_scale_V": _lu(rng, 0.05, 2.0), "linger": int(rng.integers(1, 5)), "decay": _u(rng, 0.15, 0.7)}


def _backlash(rng):
    kind = _choice(rng, ("play", "distributed", "partial", "stick_slip"))
    form = {"kind": kind}
    if kind == "distributed":
        form["radii"] = [float(r) for r in np.sort(rng.uniform(0.1, 2.0, size=6))]
        form["weights"] = [float(w) for w in rng.dirichlet(np.full(6, 1.0))]
    elif kind == "partial":
        form["coupling"] = _u(rng, 0.4, 0.9)
    elif kind == "stick_slip":
        form["dynamic_ratio"] = _u(rng, 0.2, 0.8)
    return form


def _accommodation(rng):
    law = _choice(rng, ("log", "power", "saturating"))
    return {"law": law, "c0": _lu(rng, 0.5, 20.0) if law == "log" else _lu(rng, 2.0, 50.0),
            "p": _u(rng, 0.2, 0.8), "direction": _choice(rng, ("fatigue", "training"), p=[0.6, 0.4]),
            "pattern": _choice(rng, ("uniform", "grain_size", "hot_grains", "tc_shift")),
            "eta": _u(rng, -0.8, 0.8), "shift_sign": _sign(rng, 0.7),
            "prior_cycles": 0.0 if rng.uniform() < 0.4 else _lu(rng, 1.0, 300.0)}


def _metal_plasticity(rng):
    return {"yield_rt": _u(rng, 0.15, 0.45), "softening": _u(rng, 0.2, 0.9),
            "yield_law": _choice(rng, ("power", "exponential")), "m": _u(rng, 1.0, 2.0),
            "residual": _u(rng, -0.6, 0.6), "hardening": _u(rng, 0.0, 0.4), "sign": _sign(rng)}


_DRAWERS = {
    "thermal_lag": _thermal_lag,
    "creep": _creep,
    "baseline_drift": lambda rng: _drift_form("baseline_drift", rng),
    "ambient_drift": lambda rng: _drift_form("ambient_drift", rng),
    "joule_power": _joule_power,
    "sensor_nonlinearity": _sensor,
    "reversible": _reversible,
    "interaction": _interaction,
    "first_point": _first_point,
    "gain_drift": lambda rng: _drift_form("gain_drift", rng),
    "backlash": _backlash,
    "accommodation": _accommodation,
    "metal_plasticity": _metal_plasticity,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe): kernel, shape, time scales, signs...

    Does not depend on the strength, nor on other mechanisms present.
    """
    if family not in _DRAWERS:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}")
    form = _DRAWERS[family](rng)
    form["family"] = family
    return form


__all__ = ["LIBRARY", "OUTSIDE", "draw_form"]
