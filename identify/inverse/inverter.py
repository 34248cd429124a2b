"""Inversion of a Preisach model: the heater voltage that makes the model's output equal a target.

From the present memory state the input can move up or down.  Along either
move the output of equation (22) is a quadratic of the input between two
walls of the grid and two corners of the memory curve
(:mod:`identify.inverse.path`); a fitted effect adds a known polynomial on
each piece or maps the hysterons' input to the heater voltage in closed
form (:mod:`identify.inverse.effects`).  So every voltage that reaches a
target is an exact root of a polynomial on a piece
(:mod:`identify.inverse.roots`).

**The choice rule.**  The output is not monotonic in the voltage (on the
VO2 actuator the thermal term works against the transition), so a target
may be reached by several voltages.  The inversion takes

1. the voltage **nearest the previous one** (continuity: the actuator moves
   as little as possible, and the memory curve changes as little as
   possible); each direction's candidate is the first root met moving away
   from the previous voltage;
2. of two equally near (within ``1e-12`` of the grid's span), the one of
   **least heater power** (the smaller ``|v|``).

**Unreachable targets.**  When no voltage of the window reaches the target
from the present memory state by one monotone move, the step is reported
unreachable with the **closest reachable output**, and the voltage that
gives it is applied (chosen by the same rule); the target is never
silently replaced.

**Memory.**  The memory (and each effect's state) is advanced with the
chosen voltage exactly as the forward model does
(:meth:`Inverter.apply`); the output it reports is the forward model's,
not the target, so ``predicted`` is what :meth:`PreisachModel.predict_run`
(or :meth:`~PreisachModel.predict`) gives on the voltages returned.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import IdentifyError
from ..grid import WALL_TOLERANCE
from ..memory import MemoryCurve
from .effects import LagState, NotInvertible, plan_effects, probe_run, static_part
from .path import PreisachPath
from .roots import closest_to_zero, roots_between

#: Two candidate voltages this close (relative to the grid's span) are equally near the previous one.
TIE = 1e-12
#: The output effects' terms at a step when there are none: per direction (offset, gU, gP).
_NO_OFFSETS = {True: (0.0, 0.0, 0.0), False: (0.0, 0.0, 0.0)}
#: A predicted output within this (relative to the model's output scale) of the target reaches it.
REACHED = 1e-9


@dataclass(frozen=True)
class Step:
    """One inverted target: ``target`` (um, the reading asked for), the set-point ``v`` (V), the model's
    ``predicted`` reading there (um), whether the target is ``reachable`` from the memory state it started
    in, and the ``closest`` reachable reading (um; the target itself when reachable)."""

    target: float
    v: float
    predicted: float
    reachable: bool
    closest: float


@dataclass(frozen=True)
class InverseResult:
    """A target sequence inverted in one call; arrays ``(n,)``: ``targets`` (um), ``voltages`` (V),
    ``predicted`` (um, the model on ``voltages``), ``reachable`` (bool), ``closest`` (um); ``seconds``
    the wall time of the whole call."""

    targets: np.ndarray
    voltages: np.ndarray
    predicted: np.ndarray
    reachable: np.ndarray
    closest: np.ndarray
    seconds: float

    @property
    def n_unreachable(self) -> int:
        return int(np.count_nonzero(~self.reachable))


@dataclass(slots=True)
class _Frame:
    """What one step needs: the deflection ``u`` to reach (um, after the sensor map is inverted); the
    hysterons' input range ``(lo, hi)`` (V); the thermal term's input ``theta = theta0 + x``; per direction
    (``True``: up) ``(alpha, gU, gP)``: the offset (um) and the multipliers of equation (22)'s output and of
    its Preisach part added by the output effects at this step; the lag's coefficients (or None)."""

    u: float
    lo: float
    hi: float
    theta0: float
    offsets: dict
    lag: tuple | None


class Inverter:
    """A model and its memory, stepped by targets.

    Parameters
    ----------
    model: a :class:`~identify.model.PreisachModel` (with its fitted effects).
    domain: ``(lo, hi)`` (V), the set-points allowed (default: the grid's range; must lie inside it).
    run_name: the name of the run being inverted (per-run effects of other runs are unknown on it).
    initial_V: the set-point before the first target (V), held until at rest; the memory has risen to it
        from negative saturation (the sequencer saturates at 0 V before a run).

    Raises :class:`NotInvertible` for a model this inversion cannot invert exactly.
    """

    def __init__(self, model, *, domain: tuple[float, float] | None = None, run_name: str = "target",
                 initial_V: float = 0.0) -> None:
        grid = model.grid
        lo, hi = (grid.v_min, grid.v_max) if domain is None else (float(domain[0]), float(domain[1]))
        slack = WALL_TOLERANCE * grid.step
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise IdentifyError(f"the set-point range [{lo:g}, {hi:g}] V is empty")
        if lo < grid.v_min - slack or hi > grid.v_max + slack:
            raise IdentifyError(f"the set-points [{lo:g}, {hi:g}] V reach beyond the model's grid "
                                f"[{grid.v_min:g}, {grid.v_max:g}] V, where it says nothing")
        self.model = model
        self.grid = grid
        self.run_name = run_name
        plan = plan_effects(model.effects, run_name)
        self.plan = plan
        self.static = static_part(plan.static, grid)
        self.lag = LagState(plan.lag) if plan.lag is not None else None
        loop = plan.feedback.loop() if plan.feedback is not None else None
        self.k = float(loop.k) if loop is not None else 0.0
        self.sensor = plan.sensor
        if self.lag is not None and lo < 0.0:
            lo = 0.0  # the beam heats as v^2: the lag's closed form takes v >= 0
        self.lo, self.hi = max(lo, grid.v_min), min(hi, grid.v_max)
        self.path = PreisachPath(grid, model.density, MemoryCurve(grid.levels))
        self._h, self._v0 = grid.step, grid.v_min
        self.v = self._initial_V = float(initial_V)
        self.x = max(self.v, grid.v_min)  # the hysterons' input (V): risen to the set-point from negative saturation
        self.path.apply(self._coordinate(self.x))
        self._theta = self.v
        self._deflection = model.mu0 + model.c_d * self.v + self.path.value
        self._start = (self._deflection, self.path.value)  # what the output effects count the first change from
        self._history: dict[str, list[float]] = {"v": [], "t": [], "dwell": [], "u": [], "phase": []}
        span = grid.v_max - grid.v_min
        self._tie = TIE * span
        self.scale = float(np.sum(np.abs(model.density)) + abs(model.c_d) * span + abs(model.mu0) + 1.0)
        if self.sensor is not None:
            self._check_sensor()

    # ------------------------------------------------------------ one step
    def step(self, target: float, t_s: float = math.nan, dwell_s: float = math.nan) -> Step:
        """Invert ``target`` (um) and apply the voltage found: the memory moves."""
        s = self.solve(target, t_s, dwell_s)
        predicted = self.apply(s.v, t_s, dwell_s)
        reachable = s.reachable and abs(predicted - target) <= REACHED * self.scale
        return Step(float(target), s.v, predicted, reachable, target if reachable else s.closest)

    def solve(self, target: float, t_s: float = math.nan, dwell_s: float = math.nan) -> Step:
        """The set-point for ``target`` (um) from the present memory state; nothing moves.

        ``t_s`` (s) is when the reading will be taken and ``dwell_s`` (s) how
        long after the set-point (the effects that act over time need them).
        """
        target = float(target)
        if not math.isfinite(target):
            raise IdentifyError(f"target {target!r} is not a number")
        u = self._unsense(target) if self.sensor is not None else target
        frame = self._frame(u, t_s, dwell_s)
        found = self._search(frame)
        x, reachable, value = found
        v = self._to_v(frame, x)
        reading = target if reachable else self._sense(value + u)
        return Step(target, v, reading, reachable, reading)

    # ------------------------------------------------------------ the frame of a step
    def _frame(self, u: float, t_s: float, dwell_s: float) -> _Frame:
        lag = self.lag.coefficients(dwell_s) if self.lag is not None else None
        shift = self.k * u
        lo, hi = self.lo, self.hi
        if lag is not None:
            lo_x = LagState.forward(lag, lo if lo > 0 else 5e-324) + shift
            hi_x = LagState.forward(lag, hi) + shift
        else:
            lo_x, hi_x = lo + shift, hi + shift
        g = self.grid
        lo_x, hi_x = max(lo_x, g.v_min), min(hi_x, g.v_max)
        offsets = self._offsets(t_s, dwell_s) if self.plan.offsets else _NO_OFFSETS
        return _Frame(u, lo_x, hi_x, -shift, offsets, lag)

    def _to_v(self, frame: _Frame, x: float) -> float:
        """The set-point (V) that puts the hysterons at ``x`` (V) in this step."""
        x_lag = x + frame.theta0
        v = LagState.backward(frame.lag, x_lag) if frame.lag is not None else x_lag
        return self.lo if v < self.lo else self.hi if v > self.hi else v

    def _offsets(self, t_s: float, dwell_s: float) -> dict:
        """Per direction of the move: the output effects' offset at this step and their multipliers of this
        step's equation (22) output and Preisach part, read from :meth:`Effect.contribution` on the history
        plus a candidate point (exact: they are affine in this step's output and depend on the voltage only
        through the direction of the move)."""
        h = self._history
        if not math.isfinite(t_s):
            raise NotInvertible("the model's creep acts over time: each target needs its time (t_s)")
        delta = 1e-6 * (self.grid.v_max - self.grid.v_min)
        out = {}
        for up in (True, False):
            v = h["v"] + [self.v + (delta if up else -delta)]
            run = probe_run(self.run_name, v, h["t"] + [t_s], h["dwell"] + [dwell_s], self._initial_V)
            alpha = g_u = g_p = 0.0
            for e in self.plan.offsets:
                def at(uk: float, pk: float) -> float:
                    return float(e.contribution(run, np.asarray(h["u"] + [uk]), np.asarray(h["phase"] + [pk]),
                                                self._start)[-1])

                c00 = at(0.0, 0.0)
                alpha += c00
                if e.needs_output:
                    g_u += at(1.0, 0.0) - c00
                    g_p += at(0.0, 1.0) - c00
            out[up] = (alpha, g_u, g_p)
        return out

    # ------------------------------------------------------------ the search
    def _transform(self, frame: _Frame, up: bool) -> tuple[float, float, float]:
        """``(const, slope, kp)``: on a piece of cell ``cell`` with Preisach part ``p0 + p1 f + p2 f^2`` the
        residual (output minus the deflection to reach, um) is ``const + slope cell + kp p0 + (slope + kp p1) f
        + kp p2 f^2`` (plus the static effects' polynomial), ``f = x - cell`` in grid coordinates."""
        m = self.model
        alpha, g_u, g_p = frame.offsets[up]
        k1 = 1.0 + g_u
        return (k1 * (m.mu0 + m.c_d * (frame.theta0 + self._v0)) + alpha - frame.u, k1 * m.c_d * self._h, k1 + g_p)

    def _pieces(self, frame: _Frame, up: bool):
        """``(start, end, cell, residual coefficients)`` of the move in one direction, nearest first."""
        const, slope, kp = self._transform(frame, up)
        end = ((frame.hi if up else frame.lo) - self._v0) / self._h
        st = self.static
        for s, e, cell, p0, p1, p2 in self.path.pieces(up, end):
            c = [const + slope * cell + kp * p0, slope + kp * p1, kp * p2]
            if st is None:
                yield s, e, cell, c
                continue
            lo, hi = min(s, e), max(s, e)
            inner = [b for b in st.breaks if lo < b < hi]
            edges = [s] + (inner if up else inner[::-1]) + [e]
            for a, b in zip(edges[:-1], edges[1:]):
                sc = st.coefficients[st.interval(0.5 * (a + b))]
                cc = c + [0.0] * (len(sc) - 3)
                for i, x in enumerate(sc):
                    cc[i] += x
                yield a, b, cell, cc

    def _search(self, frame: _Frame) -> tuple[float, bool, float]:
        """``(x, reachable, residual)``: the hysterons' input (V) chosen by the rule, whether it reaches the
        target, and the output minus the target there (um; 0 when reachable).

        The two moves are scanned piece by piece, always the one whose next piece starts nearer the previous
        voltage, until a root is found in each or the other's pieces start farther than the best root."""
        h, v0, v_now, tie = self._h, self._v0, self.v, self._tie
        lo_v, hi_v = self.lo, self.hi
        to_v = self._to_v
        plain = self.static is None  # the residual is a quadratic on every piece: the fast path
        if plain:
            gens = (self.path.pieces(True, (frame.hi - v0) / h), self.path.pieces(False, (frame.lo - v0) / h))
            tf = (self._transform(frame, True), self._transform(frame, False))
        else:
            gens = (self._pieces(frame, True), self._pieces(frame, False))
        shifted = frame.lag is None  # the set-point is the hysterons' input shifted: distances without to_v
        th0 = frame.theta0
        nxt = [next(gens[0], None), next(gens[1], None)]
        dist = [0.0 if p is not None else math.inf for p in nxt]  # both moves start at the present input
        best: tuple[float, float, float] | None = None  # (distance, |v|, x)
        missed = []  # pieces without a root: where the closest reachable output is, if no piece has one
        while True:
            d = 0 if dist[0] <= dist[1] else 1
            if dist[d] == math.inf or (best is not None and dist[d] > best[0] + tie):
                break
            piece = nxt[d]
            up = d == 0
            if plain:
                s, e, cell, p0, p1, p2 = piece
                const, slope, kp = tf[d]
                c0, c1, c2 = const + slope * cell + kp * p0, slope + kp * p1, kp * p2
                c = (c0, c1, c2)
            else:
                s, e, cell, c = piece
            lo, hi = (s - cell, e - cell) if up else (e - cell, s - cell)
            if plain:  # a root only where the quadratic changes sign: at the ends, or at its vertex
                a = c0 + lo * (c1 + lo * c2)
                b = c0 + hi * (c1 + hi * c2)
                maybe = a == 0.0 or b == 0.0 or (a < 0.0) != (b < 0.0)
                if not maybe and c2 != 0.0:
                    f = -0.5 * c1 / c2
                    if lo < f < hi:
                        r = c0 + f * (c1 + f * c2)
                        maybe = (r < 0.0) != (a < 0.0) or abs(r) <= 1e-12 * (abs(c0) + abs(c1) + abs(c2))
            else:
                maybe = True
            if maybe:
                roots = roots_between(c, lo, hi)
                if roots:
                    x = v0 + h * (cell + (roots[0] if up else roots[-1]))
                    v = to_v(frame, x)
                    cand = (abs(v - v_now), abs(v), x)
                    if best is None or cand[0] < best[0] - tie or (abs(cand[0] - best[0]) <= tie and cand[1] < best[1]):
                        best = cand
                    nxt[d], dist[d] = None, math.inf  # the first root met in a direction is its candidate
                    continue
            if best is None:
                missed.append((c, lo, hi, cell))
            p = nxt[d] = next(gens[d], None)
            if p is None:
                dist[d] = math.inf
            elif shifted:
                v = v0 + h * p[0] + th0
                dist[d] = abs((lo_v if v < lo_v else hi_v if v > hi_v else v) - v_now)
            else:
                dist[d] = abs(to_v(frame, v0 + h * p[0]) - v_now)
        if best is not None:
            return best[2], True, 0.0
        closest: tuple[float, float, float, float] | None = None  # (|r|, distance, |v|, x)
        closest_r = 0.0
        tol = REACHED * self.scale
        for c, lo, hi, cell in missed:
            f, r = closest_to_zero(c, lo, hi)
            x = v0 + h * (cell + f)
            v = to_v(frame, x)
            cand = (abs(r), abs(v - v_now), abs(v), x)
            if closest is None or cand[0] < closest[0] - tol or (abs(cand[0] - closest[0]) <= tol
                                                                 and cand[1:3] < closest[1:3]):
                closest, closest_r = cand, r
        if closest is None:  # no move possible at all (a window of one point): stay
            return self.x, False, self._deflection - frame.u
        return closest[3], False, closest_r

    # ------------------------------------------------------------ moving the memory
    def apply(self, v: float, t_s: float = math.nan, dwell_s: float = math.nan) -> float:
        """Apply the set-point ``v`` (V), read at ``t_s`` (s) after ``dwell_s`` (s): the memory (and every
        effect's state) moves as the forward model's; returns the model's reading there (um)."""
        v = float(v)
        if not math.isfinite(v):
            raise IdentifyError(f"set-point {v!r} is not a number")
        m = self.model
        x_lag = LagState.forward(self.lag.coefficients(dwell_s), v) if self.lag is not None else v
        theta = x_lag
        x = self._mean_field(x_lag, theta) if self.k else x_lag
        coord = self._coordinate(x)
        p = self.path.apply(coord)
        u22 = m.mu0 + m.c_d * theta + p
        deflection = u22
        if self.static is not None:
            deflection += self.static.at(self._coordinate(v))
        if self.plan.offsets:  # the history the offsets are read from
            h = self._history
            h["v"].append(v)
            h["t"].append(float(t_s))
            h["dwell"].append(float(dwell_s))
            h["u"].append(u22)
            h["phase"].append(p)
            run = probe_run(self.run_name, h["v"], h["t"], h["dwell"], self._initial_V)
            for e in self.plan.offsets:
                deflection += float(e.contribution(run, np.asarray(h["u"]), np.asarray(h["phase"]), self._start)[-1])
        if self.lag is not None:
            self.lag.advance(v, dwell_s)
        self.v, self.x, self._theta = v, x, theta
        self._deflection = deflection
        return self._sense(deflection)

    def _coordinate(self, v: float) -> float:
        """Grid coordinate of ``v`` (V), as :meth:`identify.grid.Grid.coordinates` (saturated, snapped to walls)."""
        L = self.grid.levels
        x = (v - self._v0) / self._h
        x = 0.0 if x < 0.0 else float(L) if x > L else x
        r = round(x)
        return float(r) if abs(x - r) <= WALL_TOLERANCE else x

    def _mean_field(self, x_lag: float, theta: float) -> float:
        """The hysterons' input with mean-field feedback ``x = x_lag + k (mu0 + c_d theta + P(x))``: the first
        root met moving from the present input in the direction the residual points (as
        :func:`identify.effects.compose.predict_run` solves it)."""
        m, g, k = self.model, self.grid, self.k
        b = m.mu0 + m.c_d * theta

        def residual(cell: int, p0: float, p1: float, p2: float) -> list[float]:
            return [x_lag + k * (b + p0) - g.v_min - g.step * cell, k * p1 - g.step, k * p2]

        r0 = x_lag + k * (b + self.path.value) - self.x
        if r0 == 0.0:
            return self.x
        up = r0 > 0
        if self.x > g.v_max or self.x < g.v_min:  # beyond the grid the Preisach part is constant
            x = x_lag + k * (b + self.path.value)
            if (x >= g.v_max) if self.x > g.v_max else (x <= g.v_min):
                return x  # the root is on this side of the grid's edge
        end = math.inf if up else -math.inf
        for s, e, cell, p0, p1, p2 in self.path.pieces(up, end):
            if math.isinf(e):  # past the last wall
                return x_lag + k * (b + p0)
            c = residual(cell, p0, p1, p2)
            lo, hi = (s - cell, e - cell) if up else (e - cell, s - cell)
            roots = roots_between(c, lo, hi)
            if roots:
                return g.v_min + g.step * (cell + (roots[0] if up else roots[-1]))
        return x_lag + k * (b + self.path.value)  # pragma: no cover - the loop ends beyond the grid

    # ------------------------------------------------------------ the sensor
    def _sense(self, u: float) -> float:
        return float(self.sensor.sense(np.asarray([u]))[0]) if self.sensor is not None else float(u)

    def _check_sensor(self) -> None:
        """The sensor map must be monotone over the outputs the model can give (else a reading has two
        deflections)."""
        m = self.model
        lo = m.mu0 - 2.0 * self.scale
        hi = m.mu0 + 2.0 * self.scale
        u = np.linspace(lo, hi, 4001)
        y = np.asarray(self.sensor.sense(u), dtype=float)
        if not np.all(np.diff(y) > 0):
            raise NotInvertible("the model's sensor_nonlinearity is not monotone over the outputs the model can give: "
                                "a reading would stand for two deflections; cannot invert it")
        self._sensor_grid = (u, y)

    def _unsense(self, y: float) -> float:
        """The deflection (um) whose reading is ``y`` (um): bracketed on a monotone table, then exact (Brent)."""
        from scipy.optimize import brentq

        u, r = self._sensor_grid
        k = int(np.searchsorted(r, y))
        if k == 0 or k >= r.size:
            raise IdentifyError(f"target {y:g} is beyond the readings the model's sensor map can give")
        sense = self.sensor.sense
        return float(brentq(lambda z: float(sense(np.asarray([z]))[0]) - y, u[k - 1], u[k], xtol=1e-14 * self.scale,
                            rtol=4 * np.finfo(float).eps))


def invert(model, targets, t_s=None, dwell_s=None, *, domain: tuple[float, float] | None = None,
           run_name: str = "target", initial_V: float = 0.0) -> InverseResult:
    """Invert a whole target sequence ``targets`` (um, ``(n,)``) from negative saturation, in one call.

    ``t_s`` (s) and ``dwell_s`` (s), ``(n,)`` each, are the reading times and dwells (needed by the
    effects that act over time).  See :class:`Inverter` for the rest.
    """
    y = np.asarray(targets, dtype=float).reshape(-1)
    n = y.size
    t = np.full(n, np.nan) if t_s is None else np.asarray(t_s, dtype=float).reshape(-1)
    d = np.full(n, np.nan) if dwell_s is None else np.asarray(dwell_s, dtype=float).reshape(-1)
    if t.size != n or d.size != n:
        raise IdentifyError(f"{n} targets but {t.size} times and {d.size} dwells")
    t0 = time.perf_counter()
    inv = Inverter(model, domain=domain, run_name=run_name, initial_V=initial_V)
    out = np.empty((4, n))
    ok = np.empty(n, dtype=bool)
    for k in range(n):
        s = inv.step(float(y[k]), float(t[k]), float(d[k]))
        out[:, k] = (s.v, s.predicted, s.closest, s.target)
        ok[k] = s.reachable
    return InverseResult(y, out[0], out[1], ok, out[2], time.perf_counter() - t0)


__all__ = ["InverseResult", "Inverter", "NotInvertible", "Step", "invert"]
