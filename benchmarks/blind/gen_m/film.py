"""Film stage: the VO2 grains (the base device's hysterons) and what moves them.

Input: the film's temperature as an *equivalent voltage* ``x`` (V), sampled
along the dwell; output: the phase-transition deflection (um).

Mechanisms acting here (each optional, each an exact no-op when absent):

``interaction``
    Mean-field elastic coupling: the transformation strain bends the beam, the
    bending stress shifts every grain's transition temperature
    (Clausius-Clapeyron, about -1 K/kbar along the rutile c axis).  The grains
    feel the rise ``R_eff = R + kappa * m(P / S)`` (K), solved self-consistently
    (``P`` the phase deflection, ``S`` its half swing, ``m`` a monotone kernel of
    slope 1 at 0); ``|kappa| * slope < 1``: no avalanches.
``nucleation_kinetics`` (this generator's outside mechanism)
    The metastable phase (superheated insulator, supercooled metal) keeps
    nucleating by thermal activation while the temperature is held: the longer
    the hold, the further the transition has progressed.  In the grains' terms
    the input is pushed beyond the set-point, in the direction of the last
    move, by ``delta(t_hold)`` (K) growing without bound but ever more slowly
    with the time ``t_hold`` spent at the current level.
``accommodation``
    Training or fatigue: the grains' weights change with the number of
    transformation cycles the film has gone through, ``N`` = accumulated
    |change of the phase deflection| / (4 S).  ``P = P0 + eps(N) (P1 + c S1)``
    where ``P0`` is the base film and ``P1`` a film with weights ``w * density``
    (``w`` a pattern over the Preisach plane: uniform, hysteresis width,
    transition temperature or distance from the mean transition).

Units: V, K, um, s.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import brentq

_GEOMETRY: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def cell_thresholds(device) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's switching-up and switching-down inputs (V) ``(cells,)``, probed through the public
    :class:`base.Hysteresis` interface (a one-weight film swept up from negative saturation, and down
    from positive saturation).  Cached per grid."""
    n = int(np.asarray(device.density_um).size)
    key = (device.levels, float(device.v_min_V), float(device.v_max_V), n)
    if key in _GEOMETRY:
        return _GEOMETRY[key]
    xs = np.linspace(device.v_min_V, device.v_max_V, 2 * device.levels + 1)
    up, down = np.empty(n), np.empty(n)
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        h = dataclasses.replace(device, density_um=e).hysteresis()
        lo, hi = 0, xs.size - 1  # first index switched up (peek > -0.5)
        while lo < hi:
            mid = (lo + hi) // 2
            if h.peek(xs[mid]) > -0.5:
                hi = mid
            else:
                lo = mid + 1
        up[i] = xs[lo]
        h.move(device.v_max_V)
        lo, hi = 0, xs.size - 1  # last index switched down (peek < 0.5)
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if h.peek(xs[mid]) < 0.5:
                lo = mid
            else:
                hi = mid - 1
        down[i] = xs[lo]
    _GEOMETRY[key] = (up, down)
    return up, down


def _kernel(name: str, c: float):
    if name == "linear":
        return lambda p: p
    if name == "tanh":
        return lambda p: np.tanh(c * p) / c
    if name == "softcubic":
        b = (c - 1.0) / (3.0 * c)
        return lambda p: p * (1.0 - b * p * p)
    raise ValueError(name)


class Accommodation:
    """One ``accommodation`` entry: a weight pattern and its growth law with the cycle count."""

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        rho = np.asarray(device.density_um, dtype=float)
        if form["pattern"] == "uniform":
            w = np.ones_like(rho)
        else:
            up, down = cell_thresholds(device)
            r_up, r_dn = device.kelvin_per_V2 * up ** 2, device.kelvin_per_V2 * down ** 2
            centre, width = 0.5 * (r_up + r_dn), r_up - r_dn
            feature = {"width": width, "centre": centre}.get(form["pattern"])
            if feature is None:  # tails
                m = np.sum(rho * centre) / rho.sum()
                feature = np.abs(centre - m)
            mean = np.sum(rho * feature) / rho.sum()
            std = np.sqrt(np.sum(rho * (feature - mean) ** 2) / rho.sum())
            w = np.clip((feature - mean) / max(std, 1e-9), -3.0, 3.0)
        w = w * float(form["direction"])
        self.device1 = dataclasses.replace(device, density_um=rho * w)
        self.s1 = float(np.sum(rho * w))
        self.c = {"insulating": 1.0, "symmetric": 0.0, "metallic": -1.0}[form["anchor"]]
        # a redistribution (zero net weight) moves the loop less than a uniform change of the same
        # relative size: give it 2.5 times the size so that strength 1 is as visible
        self.amp = strength * float(form["frac"]) * (1.0 if form["pattern"] == "uniform" else 2.5)
        self.law, self.n0, self.p = form["law"], float(form["cycles_scale"]), float(form["exponent"])
        self.h1 = None

    def eps(self, cycles: float) -> float:
        """Relative weight change after ``cycles`` transformation cycles (soft-capped at 0.3)."""
        n = max(cycles, 0.0)
        if self.law == "exp":
            g = (1.0 - np.exp(-n / self.n0)) / (1.0 - np.exp(-10.0 / self.n0))
        elif self.law == "log":
            g = np.log1p(n / self.n0) / np.log1p(10.0 / self.n0)
        else:
            g = (n / 10.0) ** self.p
        return float(0.3 * np.tanh(self.amp * g / 0.3))


class Kinetics:
    """One ``nucleation_kinetics`` entry: the hold-time shift (K) of the grains' input."""

    def __init__(self, form: dict, strength: float) -> None:
        r = float(form["cooling_over_heating"])
        amp = strength * float(form["shift_K"])
        self.heat, self.cool = amp / np.sqrt(r), amp * np.sqrt(r)
        self.kernel = form["kernel"]
        self.tau0, self.p = float(form["tau0_s"]), float(form["exponent"])
        self.tau, self.beta = float(form["tau_s"]), float(form["beta"])
        self.norm = 1.0 / self._f(60.0)

    def _f(self, t):
        t = np.maximum(t, 0.0)
        if self.kernel == "log":
            return np.log1p(t / self.tau0)
        if self.kernel == "power":
            return (t / self.tau0) ** self.p
        return 1.0 - np.exp(-(t / self.tau) ** self.beta)

    def shift_K(self, t_hold: np.ndarray, direction: int) -> np.ndarray:
        """Shift (K) ``(m,)`` after holds ``t_hold`` (s) ``(m,)``; heating direction +1, cooling -1."""
        if direction == 0:
            return np.zeros_like(t_hold)
        amp = self.heat if direction > 0 else -self.cool
        return amp * self.norm * self._f(t_hold)


def turning_points(start: float, xs: np.ndarray) -> list[float]:
    """The extrema of the path ``start -> xs[0] -> ... -> xs[-1]`` and its end (all the hysterons remember)."""
    out: list[float] = []
    last, d = start, 0
    for x in xs:
        x = float(x)
        if x == last:
            continue
        nd = 1 if x > last else -1
        if out and nd == d:
            out[-1] = x
        else:
            out.append(x)
        d, last = nd, x
    if not out or out[-1] != float(xs[-1]):
        out.append(float(xs[-1]))
    return out


class Film:
    """The film of one device with its film-stage mechanisms; ``start_run`` puts it in negative saturation."""

    def __init__(self, device, scales, interactions, accommodations, kinetics) -> None:
        self.device = device
        self.k = float(device.kelvin_per_V2)
        self.S = float(scales.phase_swing_um)
        self.coupling = [
            (float(f["sign"]) * s * float(f["loop_gain"]) / scales.slope_per_K, _kernel(f["kernel"], float(f["sharpness"])))
            for f, s in interactions]
        self.bound = 1.5 * sum(abs(kap) for kap, _ in self.coupling) + 1e-9
        self.acc = [Accommodation(device, scales, f, s) for f, s in accommodations]
        self.kin = [Kinetics(f, s) for f, s in kinetics]
        self.cycles = max([float(f["prior_cycles"]) for f, _ in accommodations], default=0.0)
        self.h0 = None
        self.pos = device.v_min_V
        self.p0 = -self.S

    @property
    def active(self) -> bool:
        return bool(self.coupling or self.acc or self.kin)

    def start_run(self) -> None:
        self.h0 = self.device.hysteresis()
        for a in self.acc:
            a.h1 = a.device1.hysteresis()
        self.pos = self.device.v_min_V
        self.p0 = self.h0.value()

    # -- the phase deflection with accommodation
    def _combine(self, p0: float, p1s: list[float]) -> float:
        p = p0
        for a, p1 in zip(self.acc, p1s):
            p += a.eps(self.cycles) * (p1 + a.c * a.s1)
        return p

    def _peek(self, x: float) -> float:
        if not self.acc:
            return self.h0.peek(x)
        return self._combine(self.h0.peek(x), [a.h1.peek(x) for a in self.acc])

    def _move(self, x: float) -> float:
        p0 = self.h0.move(x)
        if not self.acc:
            return p0
        p1s = [a.h1.move(x) for a in self.acc]
        self.cycles += abs(p0 - self.p0) / (4.0 * self.S)
        self.p0 = p0
        return self._combine(p0, p1s)

    def _effective(self, x: float) -> float:
        """The grains' input (V) for a film at ``x`` (V), with the mean-field stress solved self-consistently."""
        if not self.coupling:
            return x
        r = self.k * x * x

        def f(re: float) -> float:
            p = self._peek(float(np.sqrt(max(re, 0.0) / self.k))) / self.S
            return re - r - sum(kap * m(p) for kap, m in self.coupling)

        bound = self.bound
        while True:  # the bracket holds for |P| <= 1.5 S; widen it if training has grown the film beyond
            try:
                re = brentq(f, r - bound, r + bound, xtol=1e-10, rtol=1e-12)
                break
            except ValueError:
                bound *= 4.0
        return float(np.sqrt(max(re, 0.0) / self.k))

    def drive(self, xs: np.ndarray, t_hold: np.ndarray | None = None, direction: int = 0) -> float:
        """Move the film along ``xs`` (V) ``(m,)``; ``t_hold`` (s) ``(m,)`` the time at the current level
        at each sample (for the kinetics), ``direction`` the last move's sign.  Returns the phase (um)."""
        xs = np.asarray(xs, dtype=float)
        if self.kin and direction != 0:
            shift = sum(kin.shift_K(np.asarray(t_hold, dtype=float), direction) for kin in self.kin)
            xs = np.sqrt(np.maximum(self.k * xs * xs + shift, 0.0) / self.k)
        phase = None
        for x in turning_points(self.pos, xs):
            phase = self._move(self._effective(x))
            self.pos = x
        return phase

    def switch_off(self) -> None:
        """The heater goes to 0 V for minutes: every grain back to the insulating phase."""
        self.drive(np.array([self.device.v_min_V]))
