"""How each fitted effect of a model enters its inversion, or why it cannot.

The inversion looks for the hysterons' input ``x`` at which the model's
output equals the target, piece by piece along the memory curve, and then
for the heater voltage ``v`` that puts the hysterons there.  An effect can
be inverted exactly when, at the step being solved, it adds a polynomial of
``x`` on each piece or maps ``x`` to ``v`` in closed form (see
:mod:`identify.effects.base` for the stages).  Each effect says which
treatment it takes (:attr:`~identify.effects.Effect.inversion`, one of
:data:`~identify.effects.base.INVERSIONS`) or why it cannot be inverted
(:meth:`~identify.effects.Effect.inversion_refused`); the effects so far:

=======================  ======================================================================
``reversible``,          a function of the set-point alone, a polynomial between its breakpoints
``joule_power``          (a cubic spline between the walls; ``a v^2 + b v^4``): added to each piece's
                         polynomial.  Fitted once from :meth:`Effect.contribution` and checked.
``creep``                depends on the history and on the time: at the step it is a known
                         offset for each direction of the move (and, driven by the output,
                         affine in this step's output), read from :meth:`Effect.contribution`
                         on the history plus the candidate point.
``thermal_lag``          the beam is read short of its set-point: ``x^2 = A + B v^2`` (power
                         drive; ``x = A + B v`` for voltage) with ``A``, ``B`` known from the
                         slow modes' states and the step's dwell, so ``v`` has a closed form;
                         the thermal term follows ``x``.
``interaction``          (voltage drive, felt output) ``x = v + k u`` with ``u`` the target:
                         find ``x`` for the target, then ``v = x - k u``.
``baseline_drift``,      drifts of the runs they were fitted on: on a new run unknown, they
``ambient_drift``        change nothing (fitted on a run of the inverted run's name: refused).
``sensor_nonlinearity``  the reading of a deflection: a monotone map, inverted first.
=======================  ======================================================================

Refused (:class:`NotInvertible`, one line): ``first_point`` (its offset
after a turn grows with the reversing step through a saturating
exponential: no polynomial), a creep driven by the excursion since the last
reversal (its value at a reversal point depends on the next set-point), an
interaction driven by heater power or felt
through the phase transition alone, combinations whose pieces stop being
polynomials (a lagged or interacting input with set-point or
direction-dependent output effects), an effect that names no treatment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..effects import Effect
from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .roots import evaluate


class NotInvertible(IdentifyError):
    """A model (or one of its effects) that this inversion cannot invert exactly; the message says why."""


# ---------------------------------------------------------------- set-point functions (static)
#: Relative error above which a fitted static polynomial is not the effect (its family changed).
STATIC_CHECK = 1e-9


def probe_run(name: str, inputs, t_s=None, dwell_s=None, initial_V: float = 0.0) -> Run:
    """A run holding ``inputs`` (V), started from ``initial_V``, to ask an effect about (outputs are
    irrelevant to a contribution)."""
    v = np.asarray(inputs, dtype=float)
    t = np.zeros(v.size) if t_s is None else np.asarray(t_s, dtype=float)
    d = np.full(v.size, np.nan) if dwell_s is None else np.asarray(dwell_s, dtype=float)
    return Run(name, v, np.zeros(v.size), t, d, initial_V=float(initial_V))


@dataclass(frozen=True)
class StaticPart:
    """The static effects' sum as polynomials of the grid coordinate between breakpoints.

    ``breaks`` ``(B,)`` ascending grid coordinates (every wall and every
    effect knot in the grid); on ``[breaks[k], breaks[k+1]]`` the sum is
    ``evaluate(coefficients[k], x - cells[k])`` (um), ``cells[k]`` the cell
    the interval lies in.  ``degree`` is the highest degree.
    """

    breaks: tuple[float, ...]
    cells: tuple[int, ...]
    coefficients: tuple[tuple[float, ...], ...]
    degree: int

    def interval(self, x: float) -> int:
        """Index of the interval holding coordinate ``x`` (clamped to the grid)."""
        import bisect

        k = bisect.bisect_right(self.breaks, x) - 1
        return min(max(k, 0), len(self.coefficients) - 1)

    def at(self, x: float) -> float:
        """The sum at grid coordinate ``x`` (um)."""
        k = self.interval(x)
        return evaluate(self.coefficients[k], x - self.cells[k])


def static_part(effects: list[Effect], grid: Grid) -> StaticPart | None:
    """Fit the static effects' sum between breakpoints from their contributions (None without any).

    Each interval gets a polynomial of the declared degree through
    ``degree + 1`` points, checked at two more; a mismatch (the effect is no
    longer what its :attr:`~identify.effects.Effect.static_degree` says) raises :class:`NotInvertible`.
    """
    if not effects:
        return None
    L = grid.levels
    breaks = set(float(i) for i in range(L + 1))
    for e in effects:
        for knot in e.static_breakpoints_V():
            x = (knot - grid.v_min) / grid.step
            if 0.0 < x < L:
                breaks.add(x)
    br = sorted(breaks)
    degree = max(e.static_degree for e in effects)
    nodes = np.linspace(0.0, 1.0, degree + 1)
    checks = np.array([0.3141592653589793, 0.7182818284590452])
    frac = np.concatenate([nodes, checks])
    lo = np.asarray(br[:-1])
    hi = np.asarray(br[1:])
    cells = np.minimum(np.floor(lo + 1e-12), L - 1).astype(int)
    xs = lo[:, None] + (hi - lo)[:, None] * frac[None, :]
    v = grid.v_min + grid.step * xs.ravel()
    run = probe_run("static", v)
    total = np.zeros(v.size)
    for e in effects:
        total += e.contribution(run)
    total = total.reshape(xs.shape)
    coefficients = []
    scale = max(float(np.max(np.abs(total))), 1e-300)
    for k in range(lo.size):
        f = xs[k] - cells[k]
        c = np.polynomial.polynomial.polyfit(f[: degree + 1], total[k, : degree + 1], degree)
        check = np.polynomial.polynomial.polyval(f[degree + 1 :], c)
        if np.max(np.abs(check - total[k, degree + 1 :])) > STATIC_CHECK * scale:
            names = ", ".join(e.name for e in effects)
            raise NotInvertible(f"the model's effect(s) {names} are not polynomials of the heater voltage of the "
                                f"degree this inversion knows between their breakpoints; cannot invert them exactly")
        coefficients.append(tuple(float(x) for x in c))
    return StaticPart(tuple(br), tuple(int(c) for c in cells), tuple(coefficients), degree)


# ---------------------------------------------------------------- the thermal lag
class LagState:
    """The slow thermal modes of a fitted ``thermal_lag`` over the points applied so far.

    Mode ``j`` (time constant ``tau_j``, fraction ``f_j``, driven by power
    ``v^2`` or voltage ``v``) holds ``s_j``; a point with dwell ``d`` moves it
    to ``D + (s_j - D) exp(-d / tau_j)`` (``D`` the point's drive).  The
    hysterons then see ``x = sqrt(D_p + sum_p f_j e_j (s_j - D_p)) + sum_v
    f_j e_j (s_j - v)`` -- the incremental form of
    :func:`identify.effects.thermal_lag.lagged` (tests compare the two).
    """

    def __init__(self, effect: Effect) -> None:
        self.taus, self.fractions, drives = effect.modes()
        self.power = np.asarray([d == "power" for d in drives])
        self.states = np.zeros(self.taus.size)  # the run starts at 0 V, settled
        for which in (True, False):
            if np.sum(self.fractions[self.power == which]) >= 1.0:
                raise NotInvertible(f"the model's thermal_lag holds {np.sum(self.fractions[self.power == which]):g} of "
                                    "the rise in its slow modes (>= 1): the set-point no longer decides where the "
                                    "beam goes; cannot invert it")

    def copy(self) -> "LagState":
        other = LagState.__new__(LagState)
        other.taus, other.fractions, other.power = self.taus, self.fractions, self.power
        other.states = self.states.copy()
        return other

    def _keep(self, dwell_s: float) -> np.ndarray:
        d = math.inf if not math.isfinite(dwell_s) else max(dwell_s, 0.0)
        return np.exp(-d / self.taus)

    def coefficients(self, dwell_s: float) -> tuple[float, float, float, float]:
        """``(A_p, B_p, A_v, B_v)`` of a point with this dwell: ``x = sqrt(A_p + B_p v^2) + A_v + B_v v`` for
        ``v >= 0`` (no power-driven mode: ``sqrt(v^2)``)."""
        w = self.fractions * self._keep(dwell_s)
        p, q = self.power, ~self.power
        return (float(np.sum(w[p] * self.states[p])), 1.0 - float(np.sum(w[p])),
                float(np.sum(w[q] * self.states[q])), 1.0 - float(np.sum(w[q])))

    @staticmethod
    def forward(c: tuple[float, float, float, float], v: float) -> float:
        """The hysterons' input (V) for the set-point ``v`` (V) with coefficients ``c``."""
        ap, bp, av, bv = c
        root = math.sqrt(max(ap + bp * v * v, 0.0))
        return (-root if v < 0 else root) + av - (1.0 - bv) * v  # signed as v, 0 V as positive (as lagged)

    @staticmethod
    def backward(c: tuple[float, float, float, float], x: float) -> float:
        """The set-point ``v >= 0`` (V) that puts the hysterons at ``x`` (V) with coefficients ``c``."""
        ap, bp, av, bv = c
        r = x - av
        if bv == 1.0:  # no voltage-driven mode: x = sqrt(ap + bp v^2)
            return math.sqrt(max((r * r - ap) / bp, 0.0)) if r > 0 else 0.0
        # (r - (bv - 1) v)^2 = ap + bp v^2 with y = r + (1 - bv) v >= 0
        g = 1.0 - bv
        qa, qb, qc = g * g - bp, 2.0 * r * g, r * r - ap
        if abs(qa) <= 1e-15 * max(abs(qb), abs(qc), 1.0):
            return max(-qc / qb, 0.0) if qb else 0.0
        disc = max(qb * qb - 4.0 * qa * qc, 0.0)
        roots = [(-qb + s * math.sqrt(disc)) / (2.0 * qa) for s in (1.0, -1.0)]
        ok = [v for v in roots if v >= -1e-12 and r + g * v >= -1e-12]
        return max(min(ok, key=lambda v: abs(LagState.forward(c, v) - x)) if ok else 0.0, 0.0)

    def advance(self, v: float, dwell_s: float) -> None:
        """The point ``v`` (V) was applied and held for ``dwell_s`` (s; NaN: settled)."""
        drive = np.where(self.power, v * v, v)
        self.states = drive + (self.states - drive) * self._keep(dwell_s)


# ---------------------------------------------------------------- the plan
@dataclass
class EffectPlan:
    """The model's effects sorted by how the inversion treats them."""

    static: list[Effect]
    offsets: list[Effect]
    lag: Effect | None
    feedback: Effect | None
    sensor: Effect | None
    inert: list[Effect]


def _refuse(effect: Effect, why: str) -> NotInvertible:
    return NotInvertible(f"cannot invert a model with the effect {effect.name}: {why}")


def plan_effects(effects: tuple[Effect, ...] | list[Effect], run_name: str) -> EffectPlan:
    """Sort ``effects`` (fitted) by treatment, as each says (:attr:`~identify.effects.Effect.inversion`);
    :class:`NotInvertible` for what cannot be inverted exactly.

    ``run_name`` names the run being inverted: a per-run effect (a drift)
    fitted on a run of that name would be a drift of the future, which is
    refused; on any other run it is unknown and changes nothing.
    """
    plan = EffectPlan([], [], None, None, None, [])
    for e in effects:
        if not e.fitted:
            continue
        if e.per_run:
            if e.knows_run(run_name):
                raise _refuse(e, f"it was fitted on a run named {run_name!r}, the run being inverted; a drift "
                                 "is known only after the run")
            plan.inert.append(e)
            continue
        why = e.inversion_refused()
        if why is not None:
            raise _refuse(e, why)
        kind = e.inverted_as()
        if kind == "static":
            plan.static.append(e)
        elif kind == "offset":
            plan.offsets.append(e)
        elif kind == "lag":
            plan.lag = e
        elif kind == "feedback":
            plan.feedback = e
        elif kind == "sensor":
            plan.sensor = e
        else:  # "inert"
            plan.inert.append(e)
    moved = plan.lag is not None or plan.feedback is not None
    if moved and (plan.static or plan.offsets):
        what = ", ".join(e.name for e in plan.static + plan.offsets)
        inp = " and ".join(e.name for e in (plan.lag, plan.feedback) if e is not None)
        raise NotInvertible(f"cannot invert {inp} together with {what}: with the hysterons' input moved off the "
                            "set-point, those effects are no longer polynomials on the memory curve's pieces")
    return plan
