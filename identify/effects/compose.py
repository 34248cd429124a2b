"""A model with effects acting on a run: the hysterons' input, the output, each effect's contribution.

The pipeline (:mod:`identify.effects.base`): the input effects transform
the heater voltage in turn (thermal lag, ambient drift), the memory curve
sees the result, equation (22) gives the output with the thermal term on
the heater voltage (or on the lagged input), the output effects add their
contributions and the sensor effects map it to the reading.

With a feedback (an effect with a :meth:`~identify.effects.base.Effect.loop`:
``interaction``) the hysterons' input depends on the output, which
depends on the memory state the input sets.  :func:`predict_run` then
steps the memory one point at a time and solves the fixed point

    x = a + k (b + P(x))

exactly, ``a`` the input after the other input effects, ``b`` the part of
the output that does not depend on the memory (``mu0``, the thermal term,
the output effects) and ``P`` the Preisach part along the memory curve.  As
the input moves, ``x`` moves continuously from where it was -- it does not
jump to another solution -- so the solution is the *first* root of
``g(x) = a + k (b + P(x)) - x`` in the direction ``g`` points from the
previous ``x``: a quasi-static sweep of the input reaches exactly that one
(if ``g`` grows with ``x`` there, as with strong positive feedback, the
state runs away to the next stable root: an avalanche).  Between two
walls of the grid and two corners of the memory curve ``P`` is a
quadratic of ``x`` (:mod:`identify.everett`), so each piece's roots are
those of a quadratic through three of its points; beyond the grid ``P`` is
constant.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from ..forward import HysteresisState
from ..grid import Grid
from ..runs import Run
from . import pipeline_order
from .base import INPUT, OUTPUT, SENSOR, Effect, EffectNotApplicable, HostModel, start_of


def check_applicable(effects: Iterable[Effect], run: Run) -> None:
    """Raise :class:`EffectNotApplicable` when ``run`` lacks what an effect needs."""
    for e in effects:
        why = e.applicable((run,))
        if why is not None:
            raise EffectNotApplicable(f"the model's effect {e.name} cannot act on {run.name}: {why}")


def hysteron_inputs(effects: Iterable[Effect], run: Run, feedback: np.ndarray | None = None,
                    model: "HostModel | None" = None) -> tuple[np.ndarray, np.ndarray]:
    """``(x, thermal)`` ``(n,)`` each: what the memory curve sees and what the thermal term multiplies.

    ``feedback`` is the output the hysterons feel (needed with ``interaction``; ``model``'s bias and
    thermal term are taken off it when they feel only the phase-transition part)."""
    x = run.inputs
    thermal = run.inputs
    for e in pipeline_order(effects):
        if e.stage != INPUT or not e.fitted:
            continue
        fb = feedback
        loop = e.loop()
        if loop is not None and feedback is not None and model is not None:
            fb = loop.felt(feedback, model.mu0, model.c_d, thermal)
        x = e.transform(run, x, fb)
        if e.drives_thermal_term:
            thermal = x
    return x, thermal


def preisach_output(model: HostModel, x: np.ndarray, thermal: np.ndarray) -> np.ndarray:
    """Equation (22)'s output (um) with hysterons' input ``x`` and the thermal term on ``thermal``."""
    bare = model.without_effects()
    return bare.predict(x) + bare.c_d * (np.asarray(thermal, dtype=float) - np.asarray(x, dtype=float))


def output_contributions(effects: Iterable[Effect], run: Run, u: np.ndarray | None = None,
                         which: str = "all", phase: np.ndarray | None = None,
                         start: tuple[float, float] | None = None) -> np.ndarray:
    """The output effects' contributions summed (um), ``(n,)``; ``u`` equation (22)'s output and ``phase``
    its phase-transition part (for the effects that depend on them), ``start`` the two at the run's initial
    state (:func:`identify.effects.base.start_of`); ``which``: ``all``, ``static`` (those that do not) or
    ``driven`` (those that do)."""
    total = np.zeros(run.n)
    for e in effects:
        if e.stage != OUTPUT or not e.fitted:
            continue
        if (which == "static" and e.needs_output) or (which == "driven" and not e.needs_output):
            continue
        total += e.contribution(run, u, phase, start)
    return total


def sensed(effects: Iterable[Effect], u: np.ndarray) -> np.ndarray:
    """The reading for deflection ``u`` through the sensor effects."""
    for e in pipeline_order(effects):
        if e.stage == SENSOR and e.fitted:
            u = e.sense(u)
    return u


def deflection(model: HostModel, run: Run, effects: Iterable[Effect] | None = None,
               feedback: np.ndarray | None = None, memo: "FixedPointMemo | None" = None) -> np.ndarray:
    """The output before the sensor stage (um), ``(n,)``.  ``feedback``: the output the hysterons feel
    (with ``interaction``); None solves the fixed point (prediction), resumed from ``memo`` where the run
    begins as one solved before."""
    effects = list(model.effects if effects is None else effects)
    static = output_contributions(effects, run, which="static")
    inter = next((e for e in effects if e.loop() is not None), None)
    if inter is None or feedback is not None:
        x, thermal = hysteron_inputs(effects, run, feedback, model)
        u = preisach_output(model, x, thermal)
    else:  # the hysterons feel equation (22)'s output and the static contributions, or its phase part alone
        loop = inter.loop()
        others = [e for e in effects if e is not inter]
        a, thermal = hysteron_inputs(others, run, None, model)
        # x = a + k (b + P(x)): b the rest of the output, or the phase part's reference taken off P
        b = model.mu0 + model.c_d * thermal + static if loop.source == "output" else np.full(run.n, -loop.reference_um)
        u = _fixed_point(model, a, b, loop.k, loop.drive, memo) + (model.mu0 + model.c_d * thermal + loop.reference_um
                                                             if loop.source == "phase" else -static)
    phase = u - model.mu0 - model.c_d * thermal
    return u + static + output_contributions(effects, run, u, which="driven", phase=phase,
                                             start=start_of(model, run.initial_V))


def predict_run(model: HostModel, run: Run, effects: Iterable[Effect] | None = None,
                memo: "FixedPointMemo | None" = None) -> np.ndarray:
    """The model's reading (um) at every point of ``run``, ``(n,)``, from negative saturation, with
    ``effects`` (default: the model's own; none: equation (22) alone).  ``memo``: see
    :class:`FixedPointMemo` (the same numbers, faster on runs that share a beginning).

    Raises :class:`EffectNotApplicable` when the run lacks what an effect needs.
    """
    effects = list(model.effects if effects is None else effects)
    if not effects:  # equation (22) alone: the memory curve of the heater voltage
        return model.without_effects().predict(run.inputs)
    check_applicable(effects, run)
    return sensed(effects, deflection(model, run, effects, memo=memo))


def contributions(model: HostModel, run: Run) -> dict[str, np.ndarray]:
    """Each effect's contribution to the reading (um), ``(n,)`` each: the prediction minus the prediction
    with that effect left out (the others kept)."""
    full = predict_run(model, run)
    out = {}
    for e in model.effects:
        rest = [f for f in model.effects if f is not e]
        out[e.name] = full - predict_run(model, run, rest)
    return out


# ---------------------------------------------------------------- the mean-field fixed point
@dataclass(frozen=True)
class _Hysterons:
    """Equation (22)'s Preisach part alone (no bias, no thermal term): ``P`` of the fixed point."""

    grid: Grid
    density: np.ndarray
    mu0: float = 0.0
    c_d: float = 0.0


class FixedPointMemo:
    """The mean-field fixed point of the last run solved for each model, with the memory after every
    point, so that a run beginning as that one did is solved only from where the two part.

    A discriminating design (:mod:`identify.diagnosis.discriminate`) predicts the same plan with each
    candidate segment appended in turn: without it, each prediction steps the whole plan again, point by
    point.  Exact: a beginning is reused only where the hysterons' drive (``a``, ``b`` below) is bit for
    bit the same, for the same model object and loop; the numbers are those of a solve from the start.
    One memo serves one design (it holds its models); it is not shared between threads.
    """

    def __init__(self) -> None:
        self._solved: dict[tuple[int, float, str], tuple[HostModel, np.ndarray, np.ndarray, np.ndarray, list]] = {}

    def start(self, model: HostModel, a: np.ndarray, b: np.ndarray, k: float,
              drive: str) -> tuple[int, np.ndarray, list] | None:
        """For the longest beginning of ``(a, b)`` solved before, its length ``n``, ``u[:n]`` and the kept
        ``(state, x, p)`` after each of its points (``n + 1`` of them, the last one's state to be copied
        before it is stepped); None when nothing was solved for this model and loop."""
        kept = self._solved.get((id(model), float(k), drive))
        if kept is None or kept[0] is not model:
            return None
        _, ka, kb, ku, states = kept
        m = min(a.size, ka.size)
        differ = (ka[:m] != a[:m]) | (kb[:m] != b[:m])
        n = int(np.argmax(differ)) if differ.any() else m
        return n, ku[:n], states[:n + 1]

    def keep(self, model: HostModel, a: np.ndarray, b: np.ndarray, k: float, drive: str, u: np.ndarray,
             states: list) -> None:
        """Keep the run just solved: ``states[n]`` the memory, root and Preisach part after ``n`` points."""
        self._solved[(id(model), float(k), drive)] = (model, a.copy(), b.copy(), u.copy(), states)


def _copied(state: HysteresisState) -> HysteresisState:
    """An independent copy of ``state`` (its memory curve copied; the Everett table is shared, read only)."""
    out = copy.copy(state)
    out.curve = state.curve.copy()
    return out


def _fixed_point(model: HostModel, a: np.ndarray, b: np.ndarray, k: float, drive: str = "voltage",
                 memo: FixedPointMemo | None = None) -> np.ndarray:
    """``u = b + P(x)`` with ``x = a + k u`` (``x^2 = a^2 + k u`` for ``drive="power"``) at every point,
    the memory stepped point by point (from where ``memo`` has solved the same beginning before)."""
    grid = model.grid
    walls = grid.walls
    u = np.empty(a.size)
    resumed = memo.start(model, a, b, k, drive) if memo is not None else None
    if resumed is None:
        state = HysteresisState(_Hysterons(model.grid, model.density))
        x = grid.v_min  # negative saturation: the input at or below the lowest wall
        p_here = state.output
        first = 0
        states = [(_copied(state), x, p_here)] if memo is not None else None
    else:
        first, u_before, states = resumed
        u[:first] = u_before
        kept_state, x, p_here = states[first]
        state = _copied(kept_state)  # the kept one stays as it was, for the next run
    for n in range(first, a.size):
        x = _first_root(state, walls, grid.v_min, grid.step, float(a[n]), float(b[n]), k, x, p_here, drive)
        p_here = state.apply(x)
        u[n] = b[n] + p_here
        if states is not None:
            states.append((_copied(state), x, p_here))
    if memo is not None:
        memo.keep(model, a, b, k, drive, u, states)
    return u


def _target(a: float, k: float, b: float, p: float, drive: str) -> float:
    """Where the hysterons' input must be for Preisach part ``p``: ``a + k (b + p)`` or, on power, its root."""
    if drive == "power":
        return math.copysign(math.sqrt(max(a * a + k * (b + p), 0.0)), a if a else 1.0)
    return a + k * (b + p)


def _breakpoints(state, walls: np.ndarray, v_min: float, step: float, x: float, d: float) -> list[float]:
    """Where ``P`` may change its quadratic piece moving from ``x`` in direction ``d``: the walls and the
    memory curve's corners ahead (input units), nearest first."""
    a, b = state.curve.corners
    corners = v_min + step * (a if d > 0 else b)
    points = np.concatenate([walls, corners])
    ahead = points[(points - x) * d > 1e-12 * step]
    return sorted(set(ahead.tolist()), key=lambda p: (p - x) * d)


def _first_root(state, walls, v_min, step, a, b, k, x0, p0, drive="voltage") -> float:
    def g(x: float, p: float) -> float:
        return _target(a, k, b, p, drive) - x

    g0 = g(x0, p0)
    if g0 == 0.0:
        return x0
    d = 1.0 if g0 > 0 else -1.0
    lo, g_lo, p_lo = x0, g0, p0
    for hi in _breakpoints(state, walls, v_min, step, x0, d):
        p_hi = state.peek(hi)
        g_hi = g(hi, p_hi)
        if g_hi * d <= 0:
            mid = 0.5 * (lo + hi)
            if drive == "voltage":  # P is a quadratic of x on the piece: exact roots
                return _quadratic_root(lo, mid, hi, g_lo, g(mid, state.peek(mid)), g_hi, d)
            if g_hi == 0.0:  # at the breakpoint itself (on power: often 0 V, the root of the clamped target)
                return hi
            if a >= 0.0 and min(lo, hi) >= 0.0:
                # on power, for x >= 0: g > 0 exactly where h = a^2 + k (b + P(x)) - x^2 > 0, and h is a
                # quadratic of x on the piece: its root is g's, exactly (no iterations)
                def h(x: float, p: float) -> float:
                    return a * a + k * (b + p) - x * x

                h_lo, h_hi = h(lo, p_lo), h(hi, p_hi)
                if h_lo * d > 0 and h_hi * d <= 0:
                    return _quadratic_root(lo, mid, hi, h_lo, h(mid, state.peek(mid)), h_hi, d)
            from scipy.optimize import brentq

            return float(brentq(lambda x: g(x, state.peek(x)), min(lo, hi), max(lo, hi), xtol=1e-15 * step,
                                rtol=8.9e-16))
        lo, g_lo, p_lo = hi, g_hi, p_hi
    # beyond the grid P is constant: the input goes where the constant output puts it
    return _target(a, k, b, state.peek(lo + d * step), drive)


def _quadratic_root(x0: float, x1: float, x2: float, g0: float, g1: float, g2: float, d: float) -> float:
    """The root of the quadratic through ``(x_i, g_i)`` nearest to ``x0`` on ``[x0, x2]`` (``g0 * d > 0``,
    ``g2 * d <= 0``)."""
    if g2 == 0.0:
        candidates = [x2]
    else:
        candidates = []
    h = x2 - x0
    # g(t) = g0 + c1 t + c2 t^2 on t = (x - x0) / h in [0, 1]
    c2 = 2.0 * (g2 - 2.0 * g1 + g0)
    c1 = g2 - g0 - c2
    if abs(c2) <= 1e-14 * (abs(g0) + abs(g1) + abs(g2)):
        candidates.append(x0 + h * (-g0 / c1) if c1 != 0 else x2)
    else:
        disc = c1 * c1 - 4.0 * c2 * g0
        if disc >= 0:
            sq = math.sqrt(disc)
            q = -0.5 * (c1 + math.copysign(sq, c1))
            for t in (q / c2, g0 / q if q != 0 else math.inf):
                if -1e-12 <= t <= 1.0 + 1e-12:
                    candidates.append(x0 + h * min(max(t, 0.0), 1.0))
    if not candidates:  # rounding at a root on the edge
        return x2
    return min(candidates, key=lambda x: abs(x - x0))
