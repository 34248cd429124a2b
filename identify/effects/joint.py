"""Fitting a model with effects: the density and every effect's terms together, by any general method.

Equation (22) plus effects is linear in the density, the bias, the thermal
coefficient and the output effects' coefficients once the hysterons' input
and the sensor map are fixed.  So the fit alternates:

1. **a linear solve** at the current state (:class:`~identify.effects.base.Context`):
   the regressor of the current hysterons' input, the thermal term, and
   every effect's columns (:meth:`~identify.effects.base.Effect.columns`)
   as extra columns of the same problem (:class:`~identify.operators.AugmentedOperator`),
   solved by the chosen method -- ``ls`` (non-negative density, free
   terms), ``smooth_nn`` (its roughness penalty on the density only),
   ``everett`` (off-diagonal density from the curves, the rest by least
   squares);
2. **an update**: output effects take their coefficients; an input effect
   steps its parameters by its coefficients (a Gauss--Newton step on its
   secant columns), the sensor map is re-evaluated at the new output; the
   step is halved while it makes the exact residual worse.

Steps repeat until the residual stops falling (at most
:data:`MAX_ITERATIONS`); with output effects only, one solve is exact.  An
effect's nonlinear *settings* (a time constant, a sign) are chosen by the
residual over its grid (:meth:`~identify.effects.base.Effect.fit_settings_grid`),
a few Gauss--Newton steps each (of several starting points of one setting,
only the one that starts lowest: :data:`START_KEY`), then continuous ones (:attr:`~identify.effects.base.Effect.continuous`) are
refined by Brent's method on a log scale between the grid neighbours of
the best.  On noise-free data of the model's own form the
parameters are recovered to the solver's precision.

Several runs are fitted together, each from negative saturation: they are
stacked with an unmeasured input below the grid between them, which
saturates the memory (per-run effects get one set of terms per run).
"""

from __future__ import annotations

import functools
import math
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..regressor_design import Design
from ..errors import IdentifyError, MethodNotApplicable
from ..forward import predict
from ..grid import Grid
from ..methods import Problem, make_method
from ..metrics import max_abs, normalised, rmse
from ..model import PreisachModel
from ..operators import RegressorOperator
from ..runs import Run
from . import pipeline_order
from .base import INPUT, SENSOR, Columns, Context, Effect, EffectNotIdentifiable, feedback_of, start_of
from .compose import hysteron_inputs, output_contributions, sensed

#: Regressor operators of hysteron-input sequences kept by one fit (each replay of the memory curve
#: costs about 15 us per point; the fit asks for the same inputs again and again).
CACHED_OPERATORS = 24

#: Most linear solves per setting.
MAX_ITERATIONS = 40
#: Relative fall of the residual below which the iteration has converged.
TOLERANCE = 1e-12
#: Step halvings tried when a step makes the residual worse.
HALVINGS = 6
#: Lengthenings of a Gauss--Newton step tried while each lowers the residual further: STRETCH, STRETCH^2,
#: ... up to STRETCH^STRETCHES times the step.
STRETCH = 2.0
STRETCHES = 5
#: Step halvings tried in the grid search (whose steps only rank the settings: a step that does not help
#: after one halving ends the setting's search there; the chosen setting is then iterated with HALVINGS).
SEARCH_HALVINGS = 1
#: Linear solves per setting while the grid of settings is searched.
GRID_ITERATIONS = 4
#: The key of a setting that says only where an input effect's parameter starts (``interaction``'s
#: ``start``): of the settings that differ in it alone, only the one whose start leaves the smallest
#: residual (the linear terms solved there) takes the Gauss--Newton steps of the grid search.
START_KEY = "start"
#: Most evaluations of Brent's method refining a continuous setting.
REFINE_STEPS = 60
#: Relative width (log scale) at which the refinement stops.
REFINE_TOL = 1e-9


#: How the grid search's independent jobs are run: ``mapper(function, items) -> [function(item), ...]``.
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], list[Any]]


def _serial(function: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
    return [function(item) for item in items]


@dataclass(frozen=True, eq=False)
class JointFit:
    """A model fitted with its effects.

    ``model`` carries the fitted effects; ``residuals[i]`` ``(m_i,)`` is
    reading minus measurement at run ``i``'s measured rows (um); ``rmse``,
    ``nrmse``, ``max_abs`` over all of them; ``base_rmse`` the same fit's
    error without effects (equation (22) alone, same method and rows);
    ``settings`` the effects' chosen settings; ``info`` the last solve's
    diagnostics and the iteration counts.
    """

    model: PreisachModel
    method: str
    method_settings: dict[str, Any]
    runs: tuple[Run, ...]
    residuals: tuple[np.ndarray, ...]
    rmse: float
    nrmse: float
    max_abs: float
    base_rmse: float | None
    seconds: float
    settings: dict[str, dict[str, float]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class _State:
    model: PreisachModel
    effects: tuple[Effect, ...]
    rss: float
    ctx: Context
    info: dict[str, Any]


class _Stack:
    """Several runs as one input sequence, separated by a saturating input; their measured rows."""

    def __init__(self, grid: Grid, runs: tuple[Run, ...]) -> None:
        self.grid = grid
        self.runs = runs
        self.below = grid.v_min - (grid.v_max - grid.v_min)
        starts, n = [], 0
        for k, r in enumerate(runs):
            n += 1 if k else 0
            starts.append(n)
            n += r.n
        self.starts = starts
        self.n = n
        y = np.full(n, np.nan)
        for s, r in zip(starts, runs):
            y[s:s + r.n] = r.outputs
        self.outputs = y
        self.rows = np.flatnonzero(np.isfinite(y))

    def stack(self, per_run: tuple[np.ndarray, ...] | list[np.ndarray], fill: float = 0.0) -> np.ndarray:
        first = np.asarray(per_run[0])
        out = np.full((self.n,) + first.shape[1:], fill, dtype=float)
        for s, r, a in zip(self.starts, self.runs, per_run):
            out[s:s + r.n] = a
        return out


def _check(grid: Grid, runs: tuple[Run, ...], effects: list[Effect], method: str) -> None:
    names = ", ".join(r.name for r in runs)
    for e in effects:
        why = e.identifiable(runs, grid)
        if why is not None:
            raise EffectNotIdentifiable(f"{e.name} cannot be identified from {names}: {why}")
    if sum(e.stage == SENSOR for e in effects) > 1:
        raise IdentifyError("at most one sensor effect at a time")


class _Hysteresis:
    """The hysteresis part ``sum mu_ij s_ij(x) + mu0`` of a model for any hysteron-input sequence, with the
    sequences' operators cached (least recently used first out)."""

    def __init__(self, grid: Grid) -> None:
        self.grid = grid
        self.ops: OrderedDict[bytes, RegressorOperator] = OrderedDict()

    def operator(self, x: np.ndarray) -> RegressorOperator:
        key = np.ascontiguousarray(x, dtype=float).tobytes()
        op = self.ops.get(key)
        if op is None:
            op = RegressorOperator(self.grid, x, False)
            self.ops[key] = op
            if len(self.ops) > CACHED_OPERATORS:
                self.ops.popitem(last=False)
        else:
            self.ops.move_to_end(key)
        return op

    def of(self, model: PreisachModel):
        """``x -> S(x) (mu, mu0)`` (um): by the cached operator of ``x`` when there is one, else as
        :func:`~identify.forward.predict` of the model without its thermal term (the replay's Everett terms
        summed, no operator built) -- most inputs a fit evaluates (a context's first guess, an effect's
        secant) are never solved at, and the operator of those that are is built when the solve asks."""
        w = np.concatenate([model.density, [model.mu0]])
        bare = replace(model, c_d=0.0, effects=())

        def output(x: np.ndarray) -> np.ndarray:
            x = np.asarray(x, dtype=float)
            op = self.ops.get(np.ascontiguousarray(x).tobytes())
            return op.matvec(w) if op is not None else predict(bare, x)

        return output


def _deflection(hyst, model: PreisachModel, effects: tuple[Effect, ...], run: Run, fb: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The output before the sensor stage with the hysterons feeling ``fb`` (fitting's convention), and
    its equation (22) part."""
    x, thermal = hysteron_inputs(effects, run, fb, model)
    u = hyst(x) + model.c_d * thermal
    return u + output_contributions(effects, run, u, phase=u - model.mu0 - model.c_d * thermal,
                                    start=start_of(model, run.initial_V)), u


def _context(evaluator: _Hysteresis, grid: Grid, model: PreisachModel, effects: tuple[Effect, ...],
             runs: tuple[Run, ...], centre: float, half: float) -> Context:
    """The context of ``model`` with ``effects``: hysterons' inputs with the measured feedback.

    The output the hysterons feel is the measured one where measured; at
    unmeasured points it is first interpolated between measured ones, then
    replaced by the model's output computed with that feedback."""
    hyst = evaluator.of(model)
    inputs, thermal, preds, fbs, bare = [], [], [], [], []
    for r in runs:
        rows = r.rows
        fb = np.interp(np.arange(r.n), rows, r.outputs[rows]) if rows.size else np.zeros(r.n)
        u, u0 = _deflection(hyst, model, effects, r, fb)
        if rows.size < r.n and any(e.name == "interaction" and e.fitted for e in effects):
            fb = feedback_of(r, u)
            u, u0 = _deflection(hyst, model, effects, r, fb)
        x, th = hysteron_inputs(effects, r, fb, model)
        inputs.append(x)
        thermal.append(th)
        preds.append(u)
        fbs.append(fb)
        bare.append(u0)
    return Context(grid, model, runs, tuple(inputs), tuple(thermal), tuple(preds), tuple(fbs), centre, half, hyst,
                   tuple(bare))


def _rss(effects: tuple[Effect, ...], ctx: Context) -> float:
    total = 0.0
    for r, u in zip(ctx.runs, ctx.predictions):
        d = (sensed(effects, u) - r.outputs)[r.rows]
        total += float(d @ d)
    return total


class _Fitter:
    def __init__(self, grid, runs, method, method_settings, effects, thermal_term):
        self.grid = grid
        self.runs = runs
        self.method = method
        self.method_settings = dict(method_settings or {})
        self.effects = pipeline_order(effects)
        self.stack = _Stack(grid, runs)
        measured = np.concatenate([r.measured for r in runs])
        lo, hi = float(np.min(measured)), float(np.max(measured))
        self.centre, self.half = 0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12)
        self.thermal = thermal_term and not any(e.replaces_thermal_term for e in effects)
        self.solves = 0
        self.last_info: dict[str, Any] = {}
        #: A residual sum of squares at rounding level: the data are fitted exactly.
        self.exact = (1e-13 * float(np.max(np.abs(measured)))) ** 2 * measured.size
        self.hysteresis = _Hysteresis(grid)
        #: The design of the last solve: the next reuses its operator while the hysterons' inputs stay put.
        self.design: Design | None = None
        #: The grid search's origin, its model and effects and their state (:meth:`origin`).
        self._origin: tuple[PreisachModel, tuple[Effect, ...], _State] | None = None

    def __getstate__(self) -> dict[str, Any]:
        """For a helper process: without the cached operators (rebuilt there as needed)."""
        state = dict(self.__dict__)
        state.update(hysteresis=_Hysteresis(self.grid), design=None, _origin=None)
        return state

    def origin(self, model: PreisachModel, effects: tuple[Effect, ...]) -> _State:
        """The state of ``model`` with ``effects``, kept for the next call with the very same objects (the
        jobs of one grid search share their origin)."""
        kept = self._origin
        if kept is None or kept[0] is not model or kept[1] is not effects:
            kept = (model, effects, self.state(model, effects))
            self._origin = kept
        return kept[2]

    # ------------------------------------------------------------ one linear solve
    def solve(self, ctx: Context, effects: tuple[Effect, ...], settings: tuple[dict, ...], frozen: bool = False
              ) -> tuple[PreisachModel, tuple[Effect, ...]]:
        """One linear solve at ``ctx``; ``frozen`` keeps the input and sensor effects where they are (no columns)."""
        st = self.stack
        active = [not (frozen and e.stage in (INPUT, SENSOR)) for e in effects]
        cols: list[Columns] = [e.columns(ctx, s) if a else Columns(tuple(np.zeros((r.n, 0)) for r in ctx.runs), (), (), ())
                               for e, s, a in zip(effects, settings, active)]
        blocks, nonneg, owner = [], [], []
        if self.thermal:
            blocks.append(st.stack(list(ctx.thermal))[:, None])
            nonneg.append(False)
            owner.append((-1, 0))
        for k, c in enumerate(cols):
            values = st.stack([np.asarray(v, dtype=float) for v in c.values])
            for j in range(c.k):
                blocks.append(values[:, j:j + 1])
                nonneg.append(bool(c.nonneg[j]))
                owner.append((k, j))
        x = st.stack(list(ctx.inputs), fill=st.below)
        for s in st.starts[1:]:
            x[s - 1] = st.below
        # through a fitted sensor map the output moves by its slope times the model's: a Gauss--Newton step
        sensor = next((e for e in effects if e.stage == SENSOR and e.fitted), None)
        outputs, row_scale = st.outputs, None
        if sensor is not None:
            u_c = st.stack(list(ctx.predictions))
            row_scale = sensor.slope(u_c)
            outputs = st.outputs + (row_scale - 1.0) * u_c
            if not active[effects.index(sensor)]:
                # the map held where it is (no columns of its own): its correction at u_c is known, not fitted
                outputs = outputs - (sensor.sense(u_c) - u_c)
            sensor_rows = [k for k, (i, _) in enumerate(owner) if i >= 0 and effects[i].stage == SENSOR]
            for k in sensor_rows:
                blocks[k] = blocks[k] / row_scale[:, None]
        if self.thermal and np.all(self.grid.on_walls(np.concatenate([r.inputs[r.rows] for r in self.runs]))):
            raise MethodNotApplicable(
                f"{self.method} cannot identify the thermal term: every measured input sits on a wall, where v is "
                "an affine function of the diagonal cells; measure an off-wall point or drop the thermal term")
        if blocks:
            extra = np.hstack(blocks)
            scale = np.sqrt(np.mean(extra[st.rows] ** 2, axis=0))
            scale = np.where(scale > 0, scale, 1.0)
            penalty = self._penalty(cols, owner, scale, st.rows.size)
            # an input effect's linearisation is about where it is: with absolute coefficients the
            # target takes the columns times where it is, so the solve returns where it goes
            current = np.zeros(len(blocks))
            for k, e in enumerate(effects):
                if e.stage == INPUT and e.absolute and e.fitted and cols[k].k:
                    at = [j for j, (i, _) in enumerate(owner) if i == k]
                    current[at] = e.coefficients(ctx)
            if np.any(current):
                shift = extra @ current
                outputs = outputs + (shift if row_scale is None else row_scale * shift)
            target = None
            order = np.argsort(~np.asarray(nonneg), kind="stable")  # sign-constrained columns first
            extra = extra[:, order] / scale[order]
            penalty = None if penalty is None else penalty[:, order]
            k_nonneg = int(np.sum(nonneg))
        else:
            extra, order, scale, k_nonneg, penalty, target = None, np.zeros(0, int), np.zeros(0), 0, None, None
        design = Design(self.grid, x, thermal_term=False)
        if design != self.design:
            # the operator of these inputs, built once (and kept for the secants and products at them)
            self.design = design.adopt(self.hysteresis.operator(x))
        problem = Problem.on(self.design, outputs, st.rows, extra=extra, extra_nonneg=k_nonneg,
                             row_scale=row_scale, penalty=penalty, penalty_target=target)
        estimator = make_method(self.method, **self.method_settings)
        estimator.fit(problem)
        self.solves += 1
        self.last_info = dict(estimator.info_)
        self.method_settings_used = estimator.settings()
        base, coef_sorted = problem.split(estimator.parameters_)
        coef = np.empty(len(blocks))
        coef[order] = coef_sorted / scale[order] if len(blocks) else coef_sorted
        c_d = 0.0
        per_effect: list[list[float]] = [[0.0] * c.k for c in cols]
        for (k, j), value in zip(owner, coef):
            if k < 0:
                c_d = float(value)
            else:
                per_effect[k][j] = float(value)
        model = PreisachModel.from_parameters(self.grid, base, False)
        model = replace(model, c_d=c_d)
        fitted = tuple(e.with_fit(ctx, s, np.asarray(p), c) if a else e
                       for e, s, p, c, a in zip(effects, settings, per_effect, cols, active))
        return model, fitted

    @staticmethod
    def _penalty(cols: list[Columns], owner: list[tuple[int, int]], scale: np.ndarray, m: int) -> np.ndarray | None:
        """Rows ``(r, K)`` on the (unit-rms scaled) extra columns for every effect's roughness penalty:
        ``smoothing`` times the data's scale, as the diagnosis weighs it (None without penalties)."""
        pieces = []
        for k, c in enumerate(cols):
            if c.roughness is None or c.smoothing <= 0:
                continue
            idx = np.array([j for j, (i, _) in enumerate(owner) if i == k])
            sc = scale[idx]
            r = np.asarray(c.roughness, dtype=float) / np.outer(sc, sc)
            lam, vec = np.linalg.eigh(r)
            keep = lam > lam.max(initial=0.0) * 1e-12
            if not keep.any():
                continue
            weight = c.smoothing * m * idx.size / float(np.trace(r))
            rows = np.zeros((int(keep.sum()), scale.size))
            rows[:, idx] = np.sqrt(weight * lam[keep])[:, None] * vec[:, keep].T
            pieces.append(rows)
        return np.vstack(pieces) if pieces else None

    # ------------------------------------------------------------ iterate one setting to convergence
    def state(self, model: PreisachModel, effects: tuple[Effect, ...]) -> _State:
        ctx = _context(self.hysteresis, self.grid, model, effects, self.runs, self.centre, self.half)
        return _State(model, effects, _rss(effects, ctx), ctx, {})

    def converge(self, start: _State, settings: tuple[dict, ...], max_iter: int = MAX_ITERATIONS) -> _State:
        """Iterate at ``settings`` from ``start``: first the linear terms at the input effects' starting
        point, then Gauss--Newton steps (halved while they do not help) until the residual stops falling."""
        return self.iterate(self.begin(start, settings), settings, max_iter)

    def begin(self, start: _State, settings: tuple[dict, ...]) -> _State:
        """The linear terms solved with the input and sensor effects held at ``settings``' starting point."""
        effects = tuple(e.with_setting(s, start.ctx) for e, s in zip(start.effects, settings))
        return self.resolved(start.model, effects, settings)

    def resolved(self, model: PreisachModel, effects: tuple[Effect, ...], settings: tuple[dict, ...]) -> _State:
        """The state with the input and sensor effects held at ``effects`` and the linear terms solved there
        (from ``model``'s context): how a setting's start, a lengthened and a halved step are scored."""
        trial = self.state(model, effects)
        solved, fitted = self.solve(trial.ctx, trial.effects, settings, frozen=True)
        return self.state(solved, fitted)

    def iterate(self, cur: _State, settings: tuple[dict, ...], max_iter: int = MAX_ITERATIONS,
                halvings: int = HALVINGS) -> _State:
        """Gauss--Newton steps at ``settings`` from ``cur`` (a :meth:`begin`), halved (at most ``halvings``
        times a step) while they do not help, until the residual stops falling."""
        # input and sensor effects, and terms driven by (or scaling) the model's own output, need iterating
        if not any(e.stage in (INPUT, SENSOR) or e.from_base or s.get("drive") == "output"
                   for e, s in zip(cur.effects, settings)):
            return cur
        for _ in range(max_iter):
            if cur.rss <= self.exact:
                break
            model, fitted = self.solve(cur.ctx, cur.effects, settings)
            new = self.state(model, fitted)
            if new.rss > cur.rss:
                new = self._halve(cur, new, settings, halvings)
            elif new.rss < cur.rss:
                new = self._stretch(cur, new, settings)
            if new.rss >= cur.rss:
                break
            improved = cur.rss - new.rss
            cur = new
            if improved <= TOLERANCE * cur.rss or cur.rss == 0.0:
                break
        return cur

    def _stretch(self, cur: _State, new: _State, settings) -> _State:
        """Longer steps of the input effects from ``cur`` through ``new`` (2, 4, ... times it, the linear
        terms re-solved at each) while they keep lowering the residual: where the linearisation
        underestimates the step -- the output the hysterons feel held fixed in the secant while it moves
        with them -- plain steps creep towards the minimum, a fiftieth of the way a step."""
        best = new
        for h in range(1, STRETCHES + 1):
            effects = tuple(_between(a, b, STRETCH ** h) for a, b in zip(cur.effects, new.effects))
            if all(e is b for e, b in zip(effects, new.effects)):
                return best  # no input or sensor effect to move
            trial = self.resolved(cur.model, effects, settings)
            if not trial.rss < best.rss:
                break
            best = trial
        return best

    def _halve(self, cur: _State, new: _State, settings, halvings: int = HALVINGS) -> _State:
        """Shorter steps of the input effects from ``cur`` towards ``new``, the linear terms re-solved at each.

        The halving stops early when the residual rises along the step from ``cur``: with the excesses
        ``e(t)`` and ``e(t/2)`` of two halved steps over ``cur``'s residual both positive, the parabola
        through ``(0, 0)``, ``(t/2, e(t/2))`` and ``(t, e(t))`` has the slope ``(4 e(t/2) - e(t)) / t`` at
        ``cur``; when that is not negative no shorter step can help (a residual at ``t = 0`` below ``cur``'s
        only lowers the estimate, so the test errs towards halving on).  At a minimum the linearisation
        cannot resolve, each halving otherwise costs a solve to halve an excess that never changes sign."""
        best = new
        previous = None  # the excess of the last halved step
        for h in range(1, halvings + 1):
            t = 0.5 ** h
            effects = tuple(_between(a, b, t) for a, b in zip(cur.effects, new.effects))
            trial = self.resolved(cur.model, effects, settings)
            if trial.rss < best.rss:
                best = trial
            if best.rss < cur.rss:
                break
            excess = trial.rss - cur.rss
            if previous is not None and previous > 0 and excess > 0 and 4.0 * excess - previous >= 0:
                break
            previous = excess
        return best


def _between(a: Effect, b: Effect, t: float) -> Effect:
    """For input and sensor effects, parameters a fraction ``t`` of the way from ``a`` to ``b`` (from no
    effect when ``a`` is unfitted); else ``b``.  Settings (continuous ones, scales) are ``b``'s."""
    if b.stage not in (INPUT, SENSOR) or not b.fitted:
        return b
    pa = a.params or {}

    def mix(key, va, vb):
        if key in b.continuous or key in FIXED_KEYS:
            return vb
        if isinstance(vb, bool):
            return vb
        if isinstance(vb, (int, float)):
            return (va if isinstance(va, (int, float)) else 0.0) + t * (vb - (va if isinstance(va, (int, float)) else 0.0))
        if isinstance(vb, list) and vb and all(isinstance(x, (int, float)) for x in vb):
            old = np.asarray(va, dtype=float) if isinstance(va, list) and len(va) == len(vb) else np.zeros(len(vb))
            return (old + t * (np.asarray(vb, dtype=float) - old)).tolist()
        return vb

    out = {key: mix(key, pa.get(key), vb) for key, vb in b.params.items() if key != "runs"}
    if isinstance(b.params.get("runs"), dict):  # per-run splines: interpolate the coefficients
        runs = {}
        for name, entry in b.params["runs"].items():
            old = (pa.get("runs") or {}).get(name)
            runs[name] = {**entry, "coefficients": mix("coefficients", None if old is None else old["coefficients"],
                                                       entry["coefficients"])}
        out["runs"] = runs
    return type(b)(out)


#: Parameters that are not coefficients (scales, knots, settings): never interpolated by a half step.
FIXED_KEYS = ("time_constant_s", "time_constants_s", "knots_z", "centre_um", "half_range_um", "knots_s", "knots",
              "sign", "split_s")


def fit_with_effects(
    grid: Grid,
    runs: list[Run] | tuple[Run, ...],
    method: str = "ls",
    effects: list[Effect] | tuple[Effect, ...] = (),
    *,
    thermal_term: bool = True,
    settings: dict[str, Any] | None = None,
    mapper: Mapper | None = None,
) -> JointFit:
    """Identify equation (22) and ``effects`` (unfitted instances) jointly on ``runs`` by ``method``.

    ``mapper(function, items)`` (default: one after the other) runs the grid search's independent jobs --
    e.g. shared with a helper process; the result does not depend on it where the processes compute alike.

    ``thermal_term`` is dropped when an effect replaces it (``reversible``).
    Raises :class:`~identify.effects.EffectNotIdentifiable` (with the reason)
    when the runs cannot identify an effect, :class:`MethodNotApplicable`
    for a method that cannot fit extra terms (the square-design methods).
    """
    runs = tuple(runs)
    if not runs:
        raise IdentifyError("no run to fit")
    effects = list(effects)
    _check(grid, runs, effects, method)
    start_time = time.perf_counter()
    fitter = _Fitter(grid, runs, method, settings, effects, thermal_term)
    zero = fitter.state(PreisachModel(grid, np.zeros(grid.n_cells)), ())
    base = None
    if any(e.stage in (INPUT, SENSOR) or e.from_base for e in effects):
        # equation (22) alone first: where input and sensor effects (and gains of the output) are linearised from
        base_model, _ = fitter.solve(zero.ctx, (), ())
        base = fitter.state(base_model, ())
    start = base or zero
    _scan_starts(fitter, start)
    grids = [e.fit_settings_grid() for e in fitter.effects]
    chosen = [g[0] for g in grids]
    cur = _State(start.model, tuple(fitter.effects), start.rss, start.ctx, {})
    if not (len(grids) == 1 and len(grids[0]) > 1):
        # the other effects fitted before one's grid is searched (a lone effect's search starts from scratch)
        cur = fitter.converge(cur, tuple(chosen))
    for k, grid_k in enumerate(grids):
        if len(grid_k) > 1:
            cur, chosen[k] = _search(fitter, cur, chosen, k, grid_k, mapper or _serial)
    seconds = time.perf_counter() - start_time
    # an effect no step could improve on stays at zero: fitted, with zero coefficients
    final = []
    for e, s in zip(cur.effects, chosen):
        if not e.fitted:
            cols = e.columns(cur.ctx, s)
            e = e.with_fit(cur.ctx, s, np.zeros(cols.k), cols)
        final.append(e)
    cur = replace(cur, effects=tuple(final))
    model = replace(cur.model, effects=tuple(cur.effects))
    residuals = [(sensed(cur.effects, u) - r.outputs)[r.rows] for r, u in zip(runs, cur.ctx.predictions)]
    everything = np.concatenate(residuals)
    measured = np.concatenate([r.measured for r in runs])
    return JointFit(
        model=model, method=method, method_settings=getattr(fitter, "method_settings_used", {}), runs=runs,
        residuals=tuple(residuals), rmse=rmse(everything), nrmse=normalised(rmse(everything), measured),
        max_abs=max_abs(everything), seconds=seconds,
        base_rmse=None if base is None else math.sqrt(base.rss / max(measured.size, 1)),
        settings={e.name: s for e, s in zip(fitter.effects, chosen)},
        info={**fitter.last_info, "solves": fitter.solves},
    )


def _scan_starts(fitter: _Fitter, start: _State) -> None:
    """Effects that scan for their own start (:meth:`Effect.scan`): each candidate is scored by the residual
    of the linear terms solved with it held fixed (the other effects absent); a start that beats ``start``'s
    residual replaces the unfitted effect, and its own settings grid is then that start's alone."""
    for k, e in enumerate(fitter.effects):
        if e.stage != INPUT:
            continue

        def score(candidate: Effect) -> float:
            return fitter.resolved(start.model, (candidate,), ({},)).rss

        found = e.scan(score)
        if found is not None and score(found) < start.rss:
            fitter.effects[k] = found


def _grid_step(fitter: _Fitter, model: PreisachModel, effects: tuple[Effect, ...],
               job: tuple[tuple[dict, ...], int, tuple | None]) -> tuple[PreisachModel, tuple[Effect, ...], float, int]:
    """One job of the grid search (module level, so a helper process can run it): ``(settings, steps,
    begun)`` -- from ``begun`` (a model and effects :meth:`_Fitter.begin` reached), or else begun at the
    settings from ``model`` with ``effects`` (the search's origin), at most ``steps`` Gauss--Newton steps;
    the model, effects and residual sum of squares reached (the context stays behind: :meth:`_Fitter.state`
    rebuilds it alike), and the linear solves it took."""
    trial, steps, begun = job
    solves = fitter.solves
    st = fitter.begin(fitter.origin(model, effects), trial) if begun is None else fitter.state(*begun)
    if steps:
        st = fitter.iterate(st, trial, steps, SEARCH_HALVINGS)
    return st.model, st.effects, st.rss, fitter.solves - solves


def _search(fitter: _Fitter, cur: _State, chosen: list[dict], k: int, grid_k: list[dict],
            mapper: Mapper = _serial) -> tuple[_State, dict]:
    """Effect ``k``'s setting: the best of its grid (a few steps each, by ``mapper``), then its continuous
    settings refined by Brent's method on a log scale between the best's grid neighbours, then iterated to
    convergence."""
    from scipy.optimize import minimize_scalar

    fresh = list(cur.effects)
    fresh[k] = fitter.effects[k]  # each setting of the grid starts the effect afresh
    origin = replace(cur, effects=tuple(fresh))
    trials = [tuple(chosen[:k]) + (s,) + tuple(chosen[k + 1:]) for s in grid_k]
    step = functools.partial(_grid_step, fitter, origin.model, origin.effects)
    solves = fitter.solves  # the jobs' solves are counted where they ran: summed here, wherever that was
    begun = mapper(step, [(trial, 0, None) for trial in trials])
    # settings that differ only in where the effect starts: the best start alone is iterated
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(grid_k):
        groups.setdefault(tuple(sorted((key, v) for key, v in s.items() if key != START_KEY)), []).append(i)
    leaders = [min(members, key=lambda m: begun[m][2]) for members in groups.values()]
    iterated = mapper(step, [(trials[i], GRID_ITERATIONS, begun[i][:2]) for i in leaders])
    fitter.solves = solves + sum(r[3] for r in begun) + sum(r[3] for r in iterated)
    best_i, (model, effects, _, _) = min(zip(leaders, iterated), key=lambda r: r[1][2])
    best, setting = fitter.state(model, effects), grid_k[best_i]
    e = fitter.effects[k]
    for name in e.continuous:
        values = [float(s[name]) for s in grid_k]
        lo = values[max(best_i - 1, 0)]
        hi = values[min(best_i + 1, len(values) - 1)]
        if hi <= lo:
            continue
        cache: dict[float, _State] = {}
        start = best

        def score(logv: float) -> float:
            if logv not in cache:
                trial = list(chosen)
                trial[k] = {**setting, name: float(np.exp(logv))}
                cache[logv] = fitter.converge(start, tuple(trial))
            return cache[logv].rss

        minimize_scalar(score, bounds=(math.log(lo), math.log(hi)), method="bounded",
                        options={"xatol": REFINE_TOL, "maxiter": REFINE_STEPS})
        logv = min(cache, key=lambda t: cache[t].rss)
        if cache[logv].rss < best.rss:
            best = cache[logv]
            setting = {**setting, name: float(np.exp(logv))}
    trial = list(chosen)
    trial[k] = setting
    return fitter.converge(best, tuple(trial)), setting


def context_of(model: PreisachModel, runs: list[Run] | tuple[Run, ...],
               effects: tuple[Effect, ...] | None = None) -> Context:
    """The context of ``model`` with ``effects`` (default: its own) on ``runs``: where their terms are
    linearised (the hysterons feel the measured output where measured)."""
    runs = tuple(runs)
    measured = np.concatenate([r.measured for r in runs])
    lo, hi = float(np.min(measured)), float(np.max(measured))
    effects = tuple(model.effects if effects is None else effects)
    return _context(_Hysteresis(model.grid), model.grid, model.without_effects(), effects, runs,
                    0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12))
