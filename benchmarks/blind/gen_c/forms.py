"""Random *forms* of every mechanism (generator C: phenomenological, data-driven families).

A form is a JSON-safe dict: kernel / shape names, time scales, exponents, signs,
asymmetries and (for smooth random shapes) the coefficients of the shape.  It
never depends on the strength nor on the other mechanisms.  Whatever is a
*realisation* (the path of a drift, the times of its jumps) is drawn later,
from the simulation seed (see ``paths.py``).
"""

from __future__ import annotations

import numpy as np

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

#: ``thermochromic_gain`` is this generator's own outside mechanism (see README.md).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "thermochromic_gain")


def _u(rng: np.random.Generator, a: float, b: float) -> float:
    return float(rng.uniform(a, b))


def _lu(rng: np.random.Generator, a: float, b: float) -> float:
    """Log-uniform on ``[a, b]``."""
    return float(np.exp(rng.uniform(np.log(a), np.log(b))))


def _pick(rng: np.random.Generator, options: list[str], p: list[float] | None = None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


def _sign(rng: np.random.Generator, p_plus: float = 0.5) -> float:
    return 1.0 if rng.random() < p_plus else -1.0


# ---------------------------------------------------------------------------------------------
# shared sub-forms


def _drift_form(rng: np.random.Generator) -> dict:
    """The shape family of a slow wander (used by baseline, ambient and gain drifts)."""
    kind = _pick(rng, ["random_walk", "sinusoids", "jumps", "trend", "settling"])
    form: dict = {"kind": kind}
    if kind == "random_walk":
        form["smooth_s"] = _lu(rng, 60.0, 900.0)
        # mean reversion (Ornstein-Uhlenbeck) time; None-like large value = pure Brownian
        form["reversion_s"] = _lu(rng, 1800.0, 40_000.0) if rng.random() < 0.6 else 0.0
    elif kind == "sinusoids":
        form["n"] = int(rng.integers(2, 7))
        form["period_min_s"] = _lu(rng, 600.0, 2400.0)
        form["period_max_s"] = _lu(rng, 5000.0, 30_000.0)
        form["spectral_slope"] = _u(rng, 0.0, 1.5)  # amplitude ~ period**slope
    elif kind == "jumps":
        form["rate_per_h"] = _lu(rng, 0.3, 2.5)
        form["smooth_s"] = _lu(rng, 60.0, 900.0)
        form["profile"] = _pick(rng, ["logistic", "erf", "exp_settle"])
    elif kind == "trend":
        form["curvature"] = _u(rng, 0.0, 2.0)
        form["cubic"] = _u(rng, 0.0, 1.0)
    else:  # settling (warm-up / mechanical settling, possibly with an overshoot)
        form["tau_s"] = _lu(rng, 600.0, 7200.0)
        form["overshoot"] = _u(rng, 0.0, 0.7)
        form["tau_ratio"] = _lu(rng, 2.0, 6.0)
    # statisticians distrust pure laws: a little random walk on top of any kind
    form["rw_admixture"] = _u(rng, 0.0, 0.3)
    form["rw_smooth_s"] = _lu(rng, 120.0, 1200.0)
    return form


def _decay_kernel_form(rng: np.random.Generator, long: bool) -> dict:
    """A relaxation kernel psi(t) (psi(0) = 1, psi(inf) = 0) drawn from several families."""
    kernel = _pick(rng, ["andrade_log", "stretched", "power_law", "lognormal"])
    form: dict = {"kernel": kernel}
    if kernel == "andrade_log":  # log-uniform spectrum: ln t between tau_min and tau_max
        form["tau_min_s"] = _lu(rng, 1.0, 30.0)
        form["tau_max_s"] = _lu(rng, 1800.0, 21_600.0) if long else _lu(rng, 300.0, 3600.0)
    elif kernel == "stretched":  # Kohlrausch
        form["tau_s"] = _lu(rng, 20.0, 3600.0)
        form["beta"] = _u(rng, 0.2, 0.75)
    elif kernel == "power_law":  # Nutting / Curie-von Schweidler
        form["tau0_s"] = _lu(rng, 1.0, 60.0)
        form["m"] = _u(rng, 0.15, 0.7)
    else:
        form["median_s"] = _lu(rng, 30.0, 3600.0)
        form["sigma_ln"] = _u(rng, 0.5, 2.0)
    return form


# ---------------------------------------------------------------------------------------------
# library mechanisms


def _thermal_lag(rng: np.random.Generator) -> dict:
    spectrum = _pick(rng, ["lognormal", "two_lognormal", "loguniform"], [0.45, 0.3, 0.25])
    form: dict = {"spectrum": spectrum}
    if spectrum == "lognormal":
        form["median_s"] = _lu(rng, 2.0, 300.0)
        form["sigma_ln"] = _u(rng, 0.3, 1.8)
    elif spectrum == "two_lognormal":  # substrate (fast) + package (slow) populations
        form["median_s"] = _lu(rng, 2.0, 60.0)
        form["sigma_ln"] = _u(rng, 0.3, 1.2)
        form["median2_s"] = _lu(rng, 300.0, 6000.0)
        form["sigma2_ln"] = _u(rng, 0.3, 1.2)
        form["share2"] = _u(rng, 0.1, 0.5)
    else:
        form["tau_min_s"] = _lu(rng, 1.0, 20.0)
        form["tau_max_s"] = _lu(rng, 200.0, 6000.0)
    # fraction of the steady rise carried by the slow paths at strength 1 (saturating in strength)
    form["weight"] = _lu(rng, 0.008, 0.025)
    form["asymmetry"] = _pick(rng, ["none", "heating_slower", "cooling_slower"], [0.3, 0.35, 0.35])
    form["asym_ratio"] = _lu(rng, 1.3, 3.0)
    # how much of the slow part the bimorph (thermal-expansion) term sees
    form["beam_share"] = _u(rng, 0.3, 1.0)
    return form


def _creep(rng: np.random.Generator) -> dict:
    form = _decay_kernel_form(rng, long=True)
    form["driver"] = _pick(rng, ["total", "phase"])
    # lag: the deflection keeps moving towards the new shape; overshoot: the transition stress relaxes back
    form["sense"] = _pick(rng, ["lag", "overshoot"], [0.6, 0.4])
    form["fraction"] = _u(rng, 0.015, 0.04)
    form["exponent"] = _u(rng, 0.6, 1.8)  # amount ~ |unrelaxed change| ** exponent
    form["up_down_ratio"] = _lu(rng, 1.0 / 3.0, 3.0)  # amount after increases / after decreases
    form["tau_ratio_down"] = _lu(rng, 0.5, 2.0)  # time scales after decreases / after increases
    return form


def _baseline_drift(rng: np.random.Generator) -> dict:
    form = _drift_form(rng)
    form["amplitude_frac"] = _u(rng, 0.012, 0.025)  # of the output swing, at strength 1
    return form


def _ambient_drift(rng: np.random.Generator) -> dict:
    form = _drift_form(rng)
    form["amplitude_K"] = _u(rng, 0.12, 0.35)
    return form


def _gain_drift(rng: np.random.Generator) -> dict:
    form = _drift_form(rng)
    form["amplitude_rel"] = _u(rng, 0.015, 0.035)
    return form


def _joule_power(rng: np.random.Generator) -> dict:
    shape = _pick(rng, ["pure_power", "alpha_linear_T", "alpha_step", "saturating"])
    form: dict = {"shape": shape}
    if shape == "alpha_linear_T":
        form["kappa"] = _u(rng, -0.35, 0.8)
    elif shape == "alpha_step":  # expansion coefficient changes across the transition (anhysteretic)
        form["kappa"] = _u(rng, -0.5, 1.0)
        form["centre_shift_K"] = _u(rng, -5.0, 5.0)
        form["width_factor"] = _u(rng, 1.0, 3.0)
    elif shape == "saturating":
        form["gamma"] = _sign(rng) * _u(rng, 0.3, 1.5)
    form["blend"] = _u(rng, 0.7, 1.4)  # relative blend at strength 1 (scaled per device)
    return form


def _sensor_nonlinearity(rng: np.random.Generator) -> dict:
    """The PSD's map is drawn through its log-slope h(zeta) (monotone for any strength):
    y' = exp(kappa * strength * h(zeta)), zeta = (u - centre) / (half the output range)."""
    shape = _pick(rng, ["tanh", "sinh", "poly", "spline", "kinks"])
    form: dict = {"shape": shape, "centre_frac": _u(rng, -0.3, 1.3)}
    if shape in ("tanh", "sinh"):  # edge compression / edge expansion around the spot's centre
        form["scale_factor"] = _lu(rng, 0.5, 3.0)
    elif shape == "poly":
        form["b1"] = float(rng.normal(0.0, 0.6))
        form["b2"] = float(rng.normal(0.0, 1.0))
    elif shape == "spline":  # log-slope is a random smooth function
        n = int(rng.integers(4, 9))
        form["knots_frac"] = [float(k) for k in np.linspace(-0.2, 1.2, n)]  # of the output range
        form["width"] = _u(rng, 0.15, 0.4)  # in zeta units
        form["coefs"] = [float(c) for c in rng.normal(0.0, 1.0, n)]
    else:  # piecewise linear with smoothed kinks: the log-slope steps at each kink
        n = int(rng.integers(1, 4))
        form["kink_frac"] = [float(k) for k in rng.uniform(0.05, 0.95, n)]  # of the output range
        form["kink_dslope"] = [float(_sign(rng) * _u(rng, 0.3, 1.0)) for _ in range(n)]
        form["kink_width"] = [float(_lu(rng, 0.02, 0.25)) for _ in range(n)]
    form["deviation_frac"] = _u(rng, 0.012, 0.025)  # non-affine deviation at strength 1 / swing
    return form


def _reversible(rng: np.random.Generator) -> dict:
    shape = _pick(rng, ["sigmoid", "bump", "power", "cosines", "knee"])
    form: dict = {"shape": shape, "argument": _pick(rng, ["voltage", "temperature"]), "sign": _sign(rng)}
    if shape == "sigmoid":  # anhysteretic share of the transition's strain
        form["centre_shift_V"] = _u(rng, -0.4, 0.4)
        form["width_V"] = _lu(rng, 0.1, 0.8)
    elif shape == "bump":
        form["centre"] = _u(rng, 0.2, 0.95)
        form["width"] = _lu(rng, 0.04, 0.25)
    elif shape == "power":
        form["p"] = _u(rng, 2.5, 6.0)
    elif shape == "cosines":
        n = int(rng.integers(2, 6))
        form["coefs"] = [float(rng.normal(0.0, (m + 1) ** -1.5)) for m in range(n)]
    else:
        form["knee"] = _u(rng, 0.3, 0.9)
        form["width"] = _lu(rng, 0.02, 0.15)
    form["amplitude_frac"] = _u(rng, 0.006, 0.012)
    return form


def _interaction(rng: np.random.Generator) -> dict:
    return {
        "sign": _sign(rng, 0.6),
        "loop_gain": _lu(rng, 0.02, 0.06),  # at strength 1 (saturates below 0.6)
        "reference": _pick(rng, ["insulating", "centred"]),
        "units": _pick(rng, ["voltage", "temperature"]),
    }


def _first_point(rng: np.random.Generator) -> dict:
    law = _pick(rng, ["const", "linear", "sqrt", "saturating", "threshold"])
    form: dict = {"size_law": law}
    if law == "saturating":
        form["size_scale_V"] = _lu(rng, 0.1, 2.0)
    elif law == "threshold":
        form["size_scale_V"] = _u(rng, 0.2, 2.5)
        form["size_width_V"] = _lu(rng, 0.05, 0.5)
    form["sense"] = _pick(rng, ["along", "against", "fixed"])
    form["fixed_sign"] = _sign(rng)
    form["up_factor"] = _lu(rng, 0.3, 3.0)  # reversals to heating / reversals to cooling
    decay = _pick(rng, ["none", "geometric", "linear", "power"])
    form["decay"] = decay
    if decay == "geometric":
        form["ratio"] = _u(rng, 0.15, 0.6)
    elif decay == "linear":
        form["points"] = int(rng.integers(2, 5))
    elif decay == "power":
        form["q"] = _u(rng, 1.0, 3.0)
    form["overlap"] = _pick(rng, ["sum", "replace"])
    form["stage"] = _pick(rng, ["mechanics", "sensor"])
    form["amplitude_frac"] = _u(rng, 0.01, 0.025)
    return form


# ---------------------------------------------------------------------------------------------
# outside mechanisms


def _backlash(rng: np.random.Generator) -> dict:
    shape = _pick(rng, ["play", "asymmetric", "distributed", "compliant"])
    form: dict = {"shape": shape, "width_frac": _u(rng, 0.008, 0.02)}
    if shape == "asymmetric":
        form["asym_ratio"] = _lu(rng, 0.25, 4.0)
    elif shape == "distributed":
        form["n"] = int(rng.integers(3, 8))
        form["spread"] = _u(rng, 0.5, 1.5)  # log-spread of the play widths
    elif shape == "compliant":
        form["follow"] = _u(rng, 0.1, 0.5)  # fraction of motion transmitted inside the play
    return form


def _accommodation(rng: np.random.Generator) -> dict:
    counter = _pick(rng, ["throughput", "half_cycles"])
    form: dict = {"counter": counter}
    form["n0"] = _lu(rng, 5.0, 60.0) if counter == "throughput" else _lu(rng, 8.0, 100.0)
    form["law"] = _pick(rng, ["saturating", "log", "power"])
    form["q"] = _u(rng, 0.3, 0.8)
    pattern = _pick(rng, ["amplitude", "shift", "width", "patchy"])
    form["pattern"] = pattern
    form["sign"] = _sign(rng)
    if pattern == "patchy":
        n = int(rng.integers(2, 5))
        form["bumps"] = [
            [float(rng.uniform(0.0, 1.0)), float(rng.uniform(0.0, 1.0)), float(_lu(rng, 0.08, 0.3)),
             float(rng.normal())]
            for _ in range(n)
        ]
    form["epsilon"] = _u(rng, 0.02, 0.05)
    return form


def _thermochromic_gain(rng: np.random.Generator) -> dict:
    mixing = _pick(rng, ["linear", "power", "percolation"])
    form: dict = {"mixing": mixing}
    if mixing == "power":
        form["gamma"] = _lu(rng, 0.4, 3.0)
    elif mixing == "percolation":
        form["f_c"] = _u(rng, 0.25, 0.75)
        form["width"] = _u(rng, 0.05, 0.2)
    form["sign"] = _sign(rng, 0.75)  # metallic VO2 reflects more in the near IR
    form["epsilon"] = _u(rng, 0.015, 0.04)
    form["centre_frac"] = _u(rng, -0.5, 1.5)  # background centroid, in output-range units
    return form


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
    "thermochromic_gain": _thermochromic_gain,
}


def draw_form(family: str, rng: np.random.Generator) -> dict:
    """A random form of mechanism ``family`` (JSON-safe); independent of strength and of other mechanisms."""
    if family not in _DRAW:
        raise ValueError(f"unknown mechanism {family!r}")
    form = _DRAW[family](rng)
    form["family"] = family
    return form
