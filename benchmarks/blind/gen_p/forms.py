"""Random *forms* of every mechanism (kernels, shapes, time scales, signs, asymmetries).

A form is a JSON-safe dict drawn from the harness's ``rng`` only: it never depends on the
strength, on the device, nor on the other mechanisms present.  Everything that depends on the
device (the output swing, the transition temperature, the loop's steepest slope) is resolved in
``simulate``; everything that depends on the realisation (a drift's path) comes from the seed.

Size parameters (``a0``, ``f0``, ``gain0`` ...) are the size of the effect at strength 1; the
strength multiplies them (with a smooth saturation where a physical bound exists).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

LIBRARY: tuple[str, ...] = (
    "thermal_lag",
    "creep",
    "baseline_drift",
    "ambient_drift",
    "joule_power",
    "sensor_nonlinearity",
    "reversible",
    "interaction",
    "first_point",
    "gain_drift",
)

#: ``heater_aging`` is this generator's own outside mechanism (see README.md).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "heater_aging")

FAMILIES: tuple[str, ...] = LIBRARY + OUTSIDE


# --------------------------------------------------------------------------- helpers
def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _lu(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform in [lo, hi]."""
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> float:
    return 1.0 if rng.random() < p_plus else -1.0


def _pick(rng: np.random.Generator, options, p=None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


def _floats(a) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=float).ravel()]


def _prony_kww(tau: float, beta: float, n: int = 12) -> tuple[list[float], list[float]]:
    """Sum of ``n`` exponentials (non-negative weights, sum 1) close to ``exp(-(t/tau)**beta)``."""
    hi = min(10.0 ** (1.0 / beta + 0.5), 1.0e3)
    taus = np.geomspace(tau * 2.0e-3, tau * hi, n)
    t = np.geomspace(tau * 1.0e-3, tau * hi * 3.0, 300)
    t = np.concatenate(([0.0], t))
    target = np.exp(-np.power(t / tau, beta))
    a = np.exp(-t[:, None] / taus[None, :])
    w, _ = nnls(a, target)
    keep = w > 1e-6 * w.sum()
    w, taus = w[keep], taus[keep]
    return _floats(taus), _floats(w / w.sum())


def _spectrum(rng: np.random.Generator, kind: str, lo: float, hi: float) -> tuple[list[float], list[float], dict]:
    """A spectrum of relaxation times (s) and weights (sum 1) of kind ``paths``/``log_uniform``/``power``/``kww``."""
    extra: dict = {}
    if kind == "paths":
        n = int(rng.integers(1, 4))
        taus = np.sort([_lu(rng, lo, hi) for _ in range(n)])
        w = rng.dirichlet(np.full(n, 1.5))
        return _floats(taus), _floats(w), extra
    if kind == "log_uniform":
        t_lo = _lu(rng, lo, lo * 10.0)
        t_hi = _lu(rng, hi / 10.0, hi)
        taus = np.geomspace(t_lo, max(t_hi, 3.0 * t_lo), 9)
        return _floats(taus), _floats(np.full(9, 1.0 / 9.0)), extra
    if kind == "power":  # step response ~ (t / tau_min) ** -beta between the two cut-offs (diffusion)
        beta = _u(rng, 0.3, 0.7)
        t_lo = _lu(rng, lo, lo * 5.0)
        t_hi = _lu(rng, hi / 5.0, hi)
        taus = np.geomspace(t_lo, max(t_hi, 3.0 * t_lo), 10)
        w = np.power(taus, -beta)
        extra["beta"] = beta
        return _floats(taus), _floats(w / w.sum()), extra
    if kind == "kww":
        beta = _u(rng, 0.35, 0.8)
        tau = _lu(rng, lo * 3.0, hi / 3.0)
        taus, w = _prony_kww(tau, beta)
        extra.update(beta=beta, tau_kww_s=tau)
        return taus, w, extra
    raise ValueError(kind)


# --------------------------------------------------------------------------- library
def _thermal_lag(rng):
    kernel = _pick(rng, ["paths", "power", "kww"])
    taus, w, extra = _spectrum(rng, kernel, 4.0, 900.0)
    return dict(
        kernel=kernel, taus_s=taus, weights=w, **extra,
        # slow fraction still missing, averaged over 8-60 s dwells, at strength 1
        f0=_lu(rng, 0.005, 0.015),
        # cooling time constants / heating ones (convection and radiation are stronger hot)
        cool_over_heat=_lu(rng, 0.6, 1.7),
    )


def _creep(rng):
    kernel = _pick(rng, ["paths", "log_uniform", "kww"])
    taus, w, extra = _spectrum(rng, kernel, 2.0, 10800.0)
    law = _pick(rng, ["linear", "power"])
    r = _lu(rng, 0.5, 2.0)
    return dict(
        kernel=kernel, taus_s=taus, weights=w, **extra,
        c0=_lu(rng, 0.02, 0.06),           # delayed fraction of a change, at strength 1
        sign=_sign(rng, 0.75),             # +1: keeps moving the same way (delayed elasticity); -1: recovers
        driver=_pick(rng, ["total", "phase"]),
        law=law, power=_u(rng, 0.6, 1.6) if law == "power" else 1.0,
        up=float(min(1.0, r)), down=float(min(1.0, 1.0 / r)),
    )


def _drift_common(rng, kinds, p=None):
    kind = _pick(rng, kinds, p)
    f: dict = dict(kind=kind)
    if kind == "ou":
        f["tau_s"] = _lu(rng, 900.0, 10800.0)
    elif kind == "pink":
        f["tau_lo_s"] = _lu(rng, 60.0, 600.0)
        f["tau_hi_s"] = _lu(rng, 3600.0, 21600.0)
        f["gamma"] = _u(rng, 0.0, 1.0)       # 0: 1/f, 1: 1/f^2
    elif kind == "warmup":
        f["tau_s"] = _lu(rng, 300.0, 3600.0)
        f["sign"] = _sign(rng)
    elif kind == "settling":
        f["tau_s"] = _lu(rng, 60.0, 1200.0)
        f["sign"] = _sign(rng)
        f["slip_rate_per_h"] = _lu(rng, 0.3, 3.0)
        f["slip_tau_s"] = _lu(rng, 20.0, 200.0)
        f["slip_rel"] = _u(rng, 0.2, 0.6)
    elif kind == "hvac":
        f["period_s"] = _lu(rng, 600.0, 2700.0)
        f["duty"] = _u(rng, 0.3, 0.7)
        f["tau_filter_s"] = _lu(rng, 60.0, 900.0)
    elif kind == "periodic":
        f["period_s"] = _lu(rng, 900.0, 3600.0)
    elif kind == "trend":
        pass
    elif kind == "events":
        f["rate_per_h"] = _lu(rng, 0.5, 3.0)
        f["rise_s"] = _lu(rng, 30.0, 300.0)
        f["decay_s"] = _lu(rng, 300.0, 1800.0)
        f["p_warm"] = _u(rng, 0.6, 1.0)
    f["wander"] = _u(rng, 0.1, 0.4)
    f["wander_tau_s"] = _lu(rng, 900.0, 7200.0)
    return f


def _baseline_drift(rng):
    f = _drift_common(rng, ["ou", "pink", "warmup", "settling"])
    f["a0"] = _lu(rng, 0.005, 0.015)         # fraction of the output swing, at strength 1
    f["zeroed"] = bool(rng.random() < 0.5)    # operator re-zeroes the PSD at each run's start
    return f


def _ambient_drift(rng):
    f = _drift_common(rng, ["ou", "hvac", "trend", "events"])
    f["amp_K"] = _lu(rng, 0.08, 0.3)         # K, at strength 1
    f["bimorph"] = bool(rng.random() < 0.5)  # the package's warming also bends the bimorph a little
    return f


def _gain_drift(rng):
    f = _drift_common(rng, ["warmup", "ou", "pink", "periodic", "trend"])
    f["a0"] = _lu(rng, 0.006, 0.02)          # relative sensitivity change, at strength 1
    return f


def _joule_power(rng):
    shape = _pick(rng, ["power", "cte_poly", "cte_knee"])
    # a0: largest departure from the linear thermal term (fraction of the output swing) at strength 1
    f: dict = dict(shape=shape, a0=_lu(rng, 0.006, 0.02))
    if shape == "power":
        f["q"] = _u(rng, 0.85, 1.3)          # thermal term ~ rise ** q (q = 1: pure Joule)
    elif shape == "cte_poly":
        while True:
            g1, g2 = _u(rng, -0.5, 0.8), _u(rng, -0.4, 0.4)
            rho = np.linspace(0.0, 1.0, 51)
            if np.all(1.0 + g1 * rho + g2 * rho * rho > 0.2):
                break
        f["g1"], f["g2"] = g1, g2
    else:
        f["knee"] = _u(rng, 0.2, 0.8)
        f["width"] = _u(rng, 0.04, 0.2)
        f["jump"] = _u(rng, -0.5, 1.0)
    return f


def _sensor_nonlinearity(rng):
    shape = _pick(rng, ["tanh", "atan", "sinh", "cubic", "exp"])
    return dict(
        shape=shape,
        sign=_sign(rng) if shape == "exp" else 1.0,
        a0=_lu(rng, 0.008, 0.03),            # relative deviation at the far end of the range, strength 1
        center_frac=_u(rng, -0.3, 0.3),      # electrical centre of the PSD (fraction of swing/2 from 0 um)
    )


def _reversible(rng):
    shape = _pick(rng, ["sigmoid", "bump", "power", "poly"])
    f: dict = dict(shape=shape, input=_pick(rng, ["temperature", "voltage"]),
                   sign=_sign(rng), a0=_lu(rng, 0.006, 0.02))
    if shape in ("sigmoid", "bump"):
        f["center_K"] = _u(rng, -12.0, 12.0)     # from the middle of the transition
        f["width_K"] = _lu(rng, 4.0, 25.0) if shape == "sigmoid" else _lu(rng, 3.0, 15.0)
    elif shape == "power":
        f["p"] = _u(rng, 1.5, 4.0)
    else:
        th = _u(rng, 0.0, 2.0 * np.pi)
        f["c2"], f["c3"] = float(np.cos(th)), float(np.sin(th))
    return f


def _interaction(rng):
    return dict(
        sign=_sign(rng),                      # +1: transformed grains ease the rest (steeper), -1: oppose
        gain0=_u(rng, 0.015, 0.05),             # loop gain on the steepest part of the major loop, strength 1
        reference=_pick(rng, ["insulating", "centre", "metallic"]),  # stress-free state
    )


def _first_point(rng):
    law = _pick(rng, ["constant", "linear", "sqrt", "saturating"])
    r = _lu(rng, 0.3, 3.0)
    linger = bool(rng.random() < 0.5)
    polarity = _pick(rng, ["along", "against", "fixed"])
    return dict(
        law=law, x0=_lu(rng, 0.02, 0.3),
        polarity=polarity, sign=_sign(rng),
        up=float(min(1.0, r)), down=float(min(1.0, 1.0 / r)),
        rho=_u(rng, 0.2, 0.6) if linger else 0.0,
        n_linger=int(rng.integers(1, 5)) if linger else 0,
        stage=_pick(rng, ["mechanics", "sensor"]),
        a0=_lu(rng, 0.008, 0.025),
    )


# --------------------------------------------------------------------------- outside
def _backlash(rng):
    kind = _pick(rng, ["single", "distributed", "elastic"])
    f: dict = dict(kind=kind, a0=_lu(rng, 0.004, 0.015), init=_u(rng, -1.0, 1.0))
    if kind == "distributed":
        n = int(rng.integers(3, 7))
        f["widths"] = _floats(np.sort(rng.uniform(0.1, 1.0, n)))
        f["weights"] = _floats(rng.dirichlet(np.ones(n)))
    elif kind == "elastic":
        f["kappa"] = _u(rng, 0.1, 0.5)
    return f


def _accommodation(rng):
    counter = _pick(rng, ["transformed", "thermal"])
    law = _pick(rng, ["exp", "log", "power"])
    f: dict = dict(counter=counter, m=_u(rng, 1.0, 3.0), law=law, A0=_lu(rng, 0.02, 0.08))
    if law == "exp":
        f["N0"] = _lu(rng, 10.0, 300.0)
    elif law == "log":
        f["N0"] = _lu(rng, 1.0, 30.0)
    else:
        f["beta"] = _u(rng, 0.3, 1.0)
    kinds = ["amplitude", "shift", "spread"]
    n = int(rng.integers(1, 3))
    chosen = sorted(rng.choice(3, size=n, replace=False).tolist())
    comps = []
    for share, i in zip(rng.dirichlet(np.ones(n)), chosen):
        c: dict = dict(kind=kinds[i], share=float(share))
        if kinds[i] == "amplitude":
            c["stuck"] = _pick(rng, ["insulating", "decoupled"])
        elif kinds[i] == "shift":
            c["delta_V"] = _u(rng, 0.05, 0.3) * _sign(rng, 0.8)   # + : transition at lower voltage
        else:
            c["lam"] = _u(rng, 0.75, 0.9) if rng.random() < 0.6 else _u(rng, 1.1, 1.3)
        comps.append(c)
    f["components"] = comps
    return f


def _heater_aging(rng):
    law = _pick(rng, ["em", "anneal", "anneal_then_em"])
    f: dict = dict(
        law=law,
        n_current=_u(rng, 1.5, 2.5),          # Black's current-density exponent
        Ea_eV=_u(rng, 0.4, 0.9),              # activation energy
        overheat=_u(rng, 1.0, 1.5),           # heater rise / beam rise
        # external (current-limiting) resistor / heater resistance: below 1 a higher heater resistance
        # means less power, above 1 more (the heater then draws closer to the matched load)
        series_ratio=_lu(rng, 0.1, 0.6) if rng.random() < 0.6 else _lu(rng, 1.6, 4.0),
        a0=_lu(rng, 0.006, 0.02),             # |dP/P| per unit of damage, strength 1
    )
    if law == "em":
        f["m"] = _u(rng, 1.0, 1.6)
    else:
        f["D0"] = _lu(rng, 0.05, 1.0)
        f["em_weight"] = _u(rng, 0.3, 1.0) if law == "anneal_then_em" else 0.0
    return f


_DRAW = dict(
    thermal_lag=_thermal_lag, creep=_creep, baseline_drift=_baseline_drift,
    ambient_drift=_ambient_drift, joule_power=_joule_power,
    sensor_nonlinearity=_sensor_nonlinearity, reversible=_reversible,
    interaction=_interaction, first_point=_first_point, gain_drift=_gain_drift,
    backlash=_backlash, accommodation=_accommodation, heater_aging=_heater_aging,
)


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of the mechanism ``family`` (JSON-safe); independent of strength, device and other mechanisms."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}")
    form = _DRAW[family](rng)
    form["family"] = family
    return form
