"""Random forms of every mechanism (JSON-safe dicts).  See README.md for the physics and ranges.

A form never depends on the strength nor on the other mechanisms present; the size of strength 1
is set in ``mechanisms`` from the device's own scales.
"""

from __future__ import annotations

import numpy as np

from ._util import json_safe, loguniform, pick

LIBRARY = (
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
)
OUTSIDE = ("backlash", "accommodation", "interference_fringes")


# ----------------------------------------------------------------------------- spectra of time constants
def _spectrum(rng, bands, kinds=("discrete", "lognormal", "powerlaw")) -> dict:
    """Time constants and weights of a relaxation (thermal or visco-elastic)."""
    kind = pick(rng, list(kinds))
    if kind == "discrete":
        n = int(rng.integers(1, len(bands) + 1))
        chosen = sorted(int(i) for i in rng.choice(len(bands), size=n, replace=False))
        if all(i == 0 for i in chosen):  # keep one slow path: a lag of only seconds would be invisible
            chosen = [0, int(rng.integers(1, len(bands)))]
        taus = [loguniform(rng, *bands[i]) for i in chosen]
        weights = rng.dirichlet(np.full(len(taus), 1.5))
        return {"spectrum": "discrete", "taus_s": taus, "weights": list(weights)}
    lo, hi = bands[0][0], bands[-1][1]
    if kind == "lognormal":
        centre = loguniform(rng, max(lo, 15.0), hi / 3.0)
        sigma = float(rng.uniform(0.25, 1.0))
        z = np.linspace(-2.0, 2.0, 9)
        taus = centre * 10.0 ** (z * sigma)
        weights = np.exp(-0.5 * z**2)
        return {"spectrum": "lognormal", "centre_s": centre, "sigma_dec": sigma,
                "taus_s": list(taus), "weights": list(weights / weights.sum())}
    # power law over a band: a springpot / diffusive spreading (weights per log-decade ~ tau^expo)
    tmin = loguniform(rng, lo, max(lo * 8.0, 20.0))
    tmax = loguniform(rng, hi / 6.0, hi)
    expo = float(rng.uniform(-0.6, 0.4))
    taus = np.geomspace(tmin, tmax, 10)
    weights = (taus / tmin) ** expo
    return {"spectrum": "powerlaw", "exponent": expo, "taus_s": list(taus), "weights": list(weights / weights.sum())}


# ----------------------------------------------------------------------------- drift components
def _drift_component(rng, kind: str) -> dict:
    if kind == "random_walk":
        return {"kind": kind}
    if kind == "ou":
        return {"kind": kind, "tau_s": loguniform(rng, 600.0, 14_400.0)}
    if kind == "flicker":
        tmin = loguniform(rng, 120.0, 900.0)
        return {"kind": kind, "tau_min_s": tmin, "tau_max_s": tmin * loguniform(rng, 10.0, 60.0)}
    if kind == "warmup":
        return {"kind": kind, "tau_s": loguniform(rng, 300.0, 7200.0), "sign": float(pick(rng, [-1.0, 1.0])),
                "shape": pick(rng, ["rise", "decay"], p=[0.7, 0.3])}
    if kind == "hvac":
        period = loguniform(rng, 480.0, 2700.0)
        return {"kind": kind, "period_s": period, "wave": pick(rng, ["sine", "triangle", "sawtooth"]),
                "duty": float(rng.uniform(0.55, 0.9)), "filter_s": period * loguniform(rng, 0.03, 0.4)}
    if kind == "steps":
        return {"kind": kind, "rate_per_h": loguniform(rng, 0.3, 2.0), "settle_s": loguniform(rng, 5.0, 300.0)}
    if kind == "mode_hops":
        return {"kind": "steps", "rate_per_h": loguniform(rng, 0.3, 2.5), "settle_s": 0.0}
    if kind == "trend":
        return {"kind": kind}
    if kind == "log_settle":
        return {"kind": kind, "tau_s": loguniform(rng, 30.0, 1800.0), "sign": float(pick(rng, [-1.0, 1.0]))}
    raise ValueError(kind)


def _drift(rng, kinds: list[str], n_max: int = 3) -> list[dict]:
    n = int(rng.integers(1, n_max + 1))
    chosen = [kinds[int(i)] for i in rng.choice(len(kinds), size=min(n, len(kinds)), replace=False)]
    if all(k in ("steps", "mode_hops") for k in chosen):
        # a Poisson process of slips may stay empty in a run: a continuous wander always comes with it
        chosen.append(pick(rng, [k for k in kinds if k not in ("steps", "mode_hops")]))
    weights = rng.dirichlet(np.full(len(chosen), 2.0))
    comps = []
    for kind, w in zip(chosen, weights):
        comp = _drift_component(rng, kind)
        comp["weight"] = float(w) * np.sqrt(len(chosen))  # mixtures keep a comparable total size
        comps.append(comp)
    return comps


# ----------------------------------------------------------------------------- the families
def _thermal_lag(rng) -> dict:
    form = _spectrum(rng, [(3.0, 30.0), (30.0, 600.0), (600.0, 7200.0)])
    form["residual_20s"] = loguniform(rng, 0.003, 0.01)
    form["cool_over_heat"] = loguniform(rng, 0.7, 1.5) if rng.uniform() < 0.6 else 1.0
    form["convection"] = ({"gamma": float(rng.uniform(0.1, 0.6)), "exponent": pick(rng, [0.25, 0.33, 1.0])}
                          if rng.uniform() < 0.5 else None)
    form["lead_tcr"] = ({"tau_s": loguniform(rng, 20.0, 900.0), "ratio": float(rng.uniform(0.3, 1.5))}
                        if rng.uniform() < 0.35 else None)
    return form


def _creep(rng) -> dict:
    kind = pick(rng, ["discrete", "lognormal", "springpot", "log"])
    bands = [(2.0, 30.0), (30.0, 900.0), (900.0, 14_400.0)]
    if kind in ("discrete", "lognormal"):
        form = _spectrum(rng, bands, kinds=(kind,))
    else:
        alpha = float(rng.uniform(0.05, 0.5)) if kind == "springpot" else 0.0
        tmax = loguniform(rng, 3600.0, 28_800.0)
        taus = np.geomspace(1.0, tmax, 12)
        w = taus**alpha
        form = {"spectrum": kind, "alpha": alpha, "taus_s": list(taus), "weights": list(w / w.sum())}
    form["sign"] = float(pick(rng, [1.0, -1.0], p=[0.65, 0.35]))
    drv = pick(rng, ["phase", "total", "thermal", "mixed"], p=[0.4, 0.3, 0.1, 0.2])
    a_p, a_t = {"phase": (1.0, 0.0), "total": (1.0, 1.0), "thermal": (0.0, 1.0)}.get(
        drv, (float(rng.uniform(0.3, 1.0)), float(rng.uniform(0.3, 1.0))))
    form["driver"] = {"kind": drv, "phase": a_p, "thermal": a_t}
    law = pick(rng, ["linear", "quadratic", "saturating"])
    form["level_law"] = {"kind": law, "a": float(pick(rng, [-1.0, 1.0]) * rng.uniform(0.1, 0.35)),
                         "l_frac": float(rng.uniform(0.3, 1.0)), "centre_frac": float(rng.uniform(0.0, 1.0))}
    rate = pick(rng, ["none", "arrhenius", "eyring"], p=[0.4, 0.35, 0.25])
    form["rate"] = {"kind": rate, "E_eV": float(rng.uniform(0.2, 0.8)), "kappa": float(rng.uniform(0.5, 2.0))}
    form["residual_20s"] = loguniform(rng, 0.004, 0.012)
    return form


def _baseline_drift(rng) -> dict:
    return {"components": _drift(rng, ["random_walk", "ou", "flicker", "warmup", "hvac", "steps",
                                       "trend", "log_settle"])}


def _ambient_drift(rng) -> dict:
    return {"components": _drift(rng, ["hvac", "warmup", "trend", "ou", "random_walk"]),
            "package_filter_s": loguniform(rng, 60.0, 1200.0) if rng.uniform() < 0.7 else 0.0}


def _gain_drift(rng) -> dict:
    return {"components": _drift(rng, ["warmup", "hvac", "ou", "random_walk", "mode_hops", "trend"])}


def _joule_power(rng) -> dict:
    law = pick(rng, ["constant_alpha", "linear_alpha", "quadratic_alpha", "saturating", "power"])
    return {"alpha_law": law, "a": float(rng.uniform(-0.5, 1.0)), "b": float(rng.uniform(-0.4, 0.6)),
            "kappa": float(pick(rng, [-1.0, 1.0]) * rng.uniform(0.3, 1.5)), "p": float(rng.uniform(0.85, 1.25))}


def _sensor_nonlinearity(rng) -> dict:
    kernel = pick(rng, ["tanh", "erf", "algebraic", "cubic", "sinh", "exp"], p=[0.22, 0.18, 0.15, 0.15, 0.1, 0.2])
    return {"kernel": kernel, "centre_frac": float(rng.uniform(-0.8, 0.8)),
            "side_ratio": loguniform(rng, 0.6, 1.6) if rng.uniform() < 0.5 else 1.0,
            "sign": float(pick(rng, [-1.0, 1.0]))}


def _reversible(rng) -> dict:
    shape = pick(rng, ["sigmoid", "bump", "poly", "power", "softplus"])
    return {"input": pick(rng, ["voltage", "temperature"]), "shape": shape,
            "centre_frac": float(rng.uniform(0.35, 0.95)), "width_V": loguniform(rng, 0.25, 2.0),
            "a2": float(rng.uniform(-1.0, 1.0)), "a3": float(rng.uniform(-1.0, 1.0)),
            "p": float(rng.uniform(1.5, 4.0)), "sign": float(pick(rng, [-1.0, 1.0]))}


def _interaction(rng) -> dict:
    law = pick(rng, ["linear", "saturating", "asymmetric", "quadratic"])
    return {"sign": float(pick(rng, [-1.0, 1.0])), "law": law, "kappa": float(rng.uniform(0.5, 2.0)),
            "a": float(rng.uniform(-0.5, 0.5)), "b": float(rng.uniform(-0.6, 0.6))}


def _first_point(rng) -> dict:
    mode = pick(rng, ["lag", "lead", "same", "one_sided"], p=[0.35, 0.2, 0.3, 0.15])
    a_up, a_dn = float(rng.uniform(0.5, 1.5)), float(rng.uniform(0.5, 1.5))
    sign = float(pick(rng, [-1.0, 1.0]))
    if mode == "lag":          # the reading still behind: off in the direction of the previous motion
        amp_up, amp_dn = -a_up, a_dn
    elif mode == "lead":
        amp_up, amp_dn = a_up, -a_dn
    elif mode == "same":
        amp_up, amp_dn = sign * a_up, sign * a_dn
    else:
        amp_up, amp_dn = (sign * a_up, 0.0) if rng.uniform() < 0.5 else (0.0, sign * a_dn)
    return {"mode": mode, "amp_up": amp_up, "amp_down": amp_dn,
            "size_law": pick(rng, ["constant", "saturating", "power", "linear"]),
            "v0_V": loguniform(rng, 0.03, 1.5), "p": float(rng.uniform(0.3, 1.0)),
            "linger": int(rng.integers(0, 4)), "decay": pick(rng, ["geometric", "power"]),
            "rho": float(rng.uniform(0.15, 0.6)), "jitter": float(rng.uniform(0.0, 0.3))}


def _backlash(rng) -> dict:
    kind = pick(rng, ["single", "distributed", "asymmetric"])
    n = int(rng.integers(3, 7))
    return {"kind": kind, "rel_widths": list(rng.uniform(0.1, 2.0, n)), "weights": list(rng.dirichlet(np.ones(n))),
            "split": float(rng.uniform(0.2, 0.8)), "stiffness": float(rng.uniform(0.0, 0.4)),
            "init_side": float(rng.uniform(-1.0, 1.0))}


def _accommodation(rng) -> dict:
    mode = pick(rng, ["fatigue", "training", "narrowing", "widening", "shift_low", "shift_high", "mixed"])
    return {"mode": mode, "law": pick(rng, ["exp", "log", "power"]), "N0": loguniform(rng, 3.0, 100.0),
            "p": float(rng.uniform(0.3, 0.8)), "N_pre": loguniform(rng, 0.5, 40.0) if rng.uniform() < 0.6 else 0.0,
            "delta": float(rng.uniform(0.5, 1.5)), "mix": float(rng.uniform(0.3, 0.7)),
            "second": pick(rng, ["narrowing", "widening", "shift_low", "shift_high"])}


def _interference_fringes(rng) -> dict:
    lam = float(pick(rng, [0.635, 0.67, 0.78, 0.83, 0.905, 0.98, 0.985, 1.064]))
    xi = float(rng.uniform(0.6, 1.0))  # where the spill-over light samples the gap, as a fraction of the tip's
    return {"wavelength_um": lam, "spot_factor": xi, "period_um": lam / (2.0 * xi),
            "finesse_F": float(pick(rng, [0.0, rng.uniform(0.2, 4.0)])), "phase0": float(rng.uniform(0, 2 * np.pi)),
            "visibility_slope": float(rng.uniform(-0.5, 0.5)),
            "drift_rad": loguniform(rng, 0.1, 3.0) if rng.uniform() < 0.7 else 0.0,
            "drift": _drift(rng, ["ou", "random_walk", "hvac", "warmup", "mode_hops"], n_max=2)}


_DRAW = {
    "thermal_lag": _thermal_lag, "creep": _creep, "baseline_drift": _baseline_drift,
    "ambient_drift": _ambient_drift, "joule_power": _joule_power, "sensor_nonlinearity": _sensor_nonlinearity,
    "reversible": _reversible, "interaction": _interaction, "first_point": _first_point,
    "gain_drift": _gain_drift, "backlash": _backlash, "accommodation": _accommodation,
    "interference_fringes": _interference_fringes,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe): kernel, shape, time scales, signs...

    Does not depend on the strength, nor on other mechanisms present.
    """
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}; known: {LIBRARY + OUTSIDE}")
    form = _DRAW[family](rng)
    form["family"] = family
    return json_safe(form)
