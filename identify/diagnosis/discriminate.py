"""A discriminating experiment: the run that tells rival explanations of a gap apart.

When two mechanisms explain the check run alike, the data can still tell
them apart -- creep follows the history of the output's steps, a drift the
clock, a lag the dwell, a sensor map the output level -- but only on an
input chosen to make them disagree.  This is experimental design for model
discrimination (T-optimality: Atkinson & Fedorov, Biometrika 62, 1975;
Box & Hill, Technometrics 9, 1967): choose the input sequence that
maximises the predicted difference between the fitted rival models, in
noise units, within the rig's limits.

**Rivals.**  Each :class:`Rival` is the base model with one candidate's
fitted effect(s) attached (or none: the base model itself), plus what it
may re-fit on a new run: the size of its own effect, the bias, the thermal
term, and, for a per-run nuisance (a drift), that run's own nuisance.  A
per-run nuisance is unknown on a new run; a rival that is one predicts the
new run with the realisation it had on the check run (:func:`as_plan`): a
drift of that size and smoothness.  A difference a rival's re-fit absorbs
is no difference, so the separation of ``A`` from ``B`` on a run -- how
surely ``B`` is rejected when ``A`` is true -- is the part of
``f_A - f_B`` that ``B``'s re-fit columns ``J_B`` cannot reproduce::

    S_AB = || (I - J_B pinv(J_B)) (f_A - f_B) || / sigma

and the pair's separation is ``min(S_AB, S_BA)`` (``S_AB`` alone when ``B`` is
the base model, nested in ``A``: ``A`` re-fits its size to zero); a plan's, the smallest
over the pairs of rivals (each pair must be told apart), and over the
parameter sets each rival is given (its fit, and fits on parts of the data:
robust to what the data leave uncertain).

**The design** (:func:`design`) is greedy: from negative saturation, it
appends, while the budget (points and rig time) lasts, the candidate
segment -- a step to a level held for one or several readings at short to
long dwells, a small reversal and back, a ramp, a return to a level visited
before -- that adds most separation per share of the budget it uses.
Inputs stay inside ``[v_min, v_max]``.  Pure: arrays and models in, a
:class:`Plan` out.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import combinations
from typing import Callable

import numpy as np

from ..effects import Context, Effect, EffectNotApplicable
from ..effects.compose import FixedPointMemo
from ..errors import IdentifyError
from ..model import PreisachModel
from ..runs import Run

#: A plan is written only when it separates the rivals by at least this many noise levels (a likelihood
#: ratio of exp(S^2 / 2) between them: decisive).
TARGET_SEPARATION = 4.0
#: Dwells (s) the segments try.
DWELLS_S = (8.0, 30.0, 120.0, 600.0)
#: Levels (fractions of the window) the steps go to.
LEVELS = (0.0, 0.15, 0.3, 0.45, 0.55, 0.7, 0.85, 1.0)
#: Candidate segments tried at each greedy step (drawn from all, seeded).
TRIED_PER_STEP = 10
#: Readings of a step-and-hold segment (one set-point applied again and read at each dwell): what follows
#: the clock and what follows the step come apart over them.
HOLD_READINGS = (3, 6)
#: Rivals a plan separates: the top two, the top three when the verdict is ``unexplained``.
RIVALS = 2
RIVALS_UNEXPLAINED = 3


@dataclass(frozen=True, eq=False)
class Rival:
    """One explanation: ``models`` the base model with its fitted effect(s) (several parameter sets of it,
    the first its fit), and ``nuisance(run) -> (n, k)`` the columns it re-fits on a new run beyond its own
    size, the bias and the thermal term (a drift's splines), or None."""

    name: str
    models: tuple[PreisachModel, ...]
    nuisance: Callable[[Run], np.ndarray] | None = None


@dataclass(frozen=True, eq=False)
class Plan:
    """Set-points ``v_V`` and dwells ``dwell_s`` ``(n,)``; ``separation`` (noise levels) the smallest over
    the pairs of rivals, ``pairs`` each pair's (``"A|B"``)."""

    v_V: np.ndarray
    dwell_s: np.ndarray
    separation: float
    pairs: dict[str, float] = field(default_factory=dict)

    @property
    def points(self) -> int:
        return int(self.v_V.size)

    @property
    def rig_time_s(self) -> float:
        return float(np.sum(self.dwell_s))


def probe(v_V: np.ndarray, dwell_s: np.ndarray, readings: int | None = None, name: str = "plan",
          initial_V: float = 0.0) -> Run:
    """A run of set-points ``v_V`` held ``dwell_s`` each, read at the end of each dwell, from negative
    saturation at ``initial_V``: what a model is asked to predict (its outputs are irrelevant)."""
    v = np.asarray(v_V, dtype=float)
    d = np.asarray(dwell_s, dtype=float)
    return Run(name, v, np.zeros(v.size), np.cumsum(d), d, readings, initial_V)


def as_plan(effect, run_name: str, plan_name: str = "plan"):
    """A fitted per-run effect (a drift) that acts on a run named ``plan_name`` as it did on ``run_name``
    (its realisation there, on the plan's clock): how a rival that is a drift predicts a new run."""
    runs = dict((effect.params or {}).get("runs", {}))
    if run_name not in runs:
        return effect
    return type(effect)({**effect.params, "runs": {**runs, plan_name: runs[run_name]}})


def _refit_columns(rival: Rival, base: np.ndarray, own: np.ndarray, run: Run,
                   nuisance: np.ndarray | None = None) -> np.ndarray:
    """What ``rival`` re-fits on ``run`` ``(n, k)``: its effect's size, the bias, the thermal term, its nuisance
    (``nuisance``: ``rival.nuisance(run)`` when already built)."""
    cols = [np.ones(run.n), run.inputs]
    size = own - base
    if np.any(np.abs(size) > 0):
        cols.append(size)
    out = np.column_stack(cols)
    if rival.nuisance is not None:
        out = np.hstack([out, rival.nuisance(run) if nuisance is None else nuisance])
    return out


def _unexplained(diff: np.ndarray, cols: np.ndarray) -> float:
    """``|| (I - P) diff ||``, ``P`` the projection on ``cols``' span."""
    coef, *_ = np.linalg.lstsq(cols, diff, rcond=None)
    return float(np.linalg.norm(diff - cols @ coef))


def _nested(big: Rival, small: Rival) -> bool:
    """Whether ``small`` is the base model alone and ``big`` is not (``small`` nested in ``big``)."""
    return not small.models[0].effects and bool(big.models[0].effects)


def separation(rivals: list[Rival], base: PreisachModel, run: Run, sigma: float,
               memo: FixedPointMemo | None = None) -> tuple[float, dict[str, float]]:
    """The plan's separation (noise levels, the smallest over pairs and parameter sets) and each pair's.
    ``memo``: kept between calls on runs that share their beginning (:func:`design`'s), the same numbers."""
    if sigma <= 0:
        raise IdentifyError("the noise level must be positive to design a discriminating run")
    f0 = base.predict(run.inputs)
    try:
        preds = [[m.predict_run(run, memo=memo) for m in r.models] for r in rivals]
    except EffectNotApplicable:  # a plan too short for an effect to act (one point: no time)
        return 0.0, {f"{a.name}|{b.name}": 0.0 for a, b in combinations(rivals, 2)}
    nuisances: dict[int, np.ndarray] = {}
    refits: dict[tuple[int, int], np.ndarray] = {}

    def refit(i: int, m: int) -> np.ndarray:
        """Rival ``i``'s re-fit columns with its parameter set ``m``: built once per run (a drift's nuisance,
        secants of the whole run, is most of a design's time), whichever pairs ask for them."""
        if (i, m) not in refits:
            if rivals[i].nuisance is not None and i not in nuisances:
                nuisances[i] = rivals[i].nuisance(run)
            refits[i, m] = _refit_columns(rivals[i], f0, preds[i][m], run, nuisances.get(i))
        return refits[i, m]

    pairs = {}
    for (i, a), (j, b) in combinations(enumerate(rivals), 2):
        worst = np.inf
        for ma, fa in enumerate(preds[i]):
            for mb, fb in enumerate(preds[j]):
                d = fa - fb
                # the base model alone is nested in any rival: only its own re-fit can reject it (the
                # bigger model re-fits its size to zero and reproduces it exactly)
                s_ab = _unexplained(d, refit(j, mb)) if not _nested(b, a) else np.inf
                s_ba = _unexplained(d, refit(i, ma)) if not _nested(a, b) else np.inf
                worst = min(worst, s_ab, s_ba)
        pairs[f"{a.name}|{b.name}"] = float(worst / sigma)
    return (min(pairs.values()) if pairs else 0.0), pairs


def _segments(x0: float, visited: list[float], lo: float, hi: float) -> list[tuple[list[float], list[float]]]:
    """Every candidate segment from the input ``x0``: ``(set-points, dwells)``."""
    span = hi - lo
    out: list[tuple[list[float], list[float]]] = []
    for f in LEVELS:
        x = lo + f * span
        for d in DWELLS_S:
            for k in HOLD_READINGS:  # one step held and read k times
                out.append(([x] * k, [d] * k))
    for delta in (0.05, 0.2):
        for sign in (1.0, -1.0):
            y = min(max(x0 + sign * delta * span, lo), hi)
            if y != x0:
                out.append(([y, x0] * 3, [15.0] * 6))  # small reversals and back
    for end in (lo, hi):
        if end != x0:
            out.append((list(np.linspace(x0, end, 5)[1:]), [8.0] * 4))  # a ramp
    for x in visited[-6:]:
        out.append(([x] * 3, [30.0] * 3))  # a return to a level visited before
    return out


def design(rivals: list[Rival], base: PreisachModel, v_min: float, v_max: float, sigma: float, *,
           points: int = 360, rig_time_s: float | None = None, readings: int | None = None,
           seed: int = 0) -> Plan:
    """The greedy discriminating plan (see the module doc) within ``points`` set-points and ``rig_time_s``
    seconds of dwell (None: no limit on time), inputs on ``[v_min, v_max]`` (V); ``sigma`` the noise of one
    reading (um)."""
    if len(rivals) < 2:
        raise IdentifyError("a discriminating run needs at least two rivals")
    if not v_max > v_min:
        raise IdentifyError(f"the window needs v_max > v_min, got [{v_min}, {v_max}]")
    rng = np.random.default_rng(seed)
    lo, hi = float(v_min), float(v_max)
    v: list[float] = []
    dwell: list[float] = []
    score, pairs = 0.0, {}
    budget_t = np.inf if rig_time_s is None else float(rig_time_s)
    memo = FixedPointMemo()  # every option below begins with the plan so far
    while len(v) < points:
        x0 = v[-1] if v else lo
        options = _segments(x0, v, lo, hi)
        picks = rng.choice(len(options), size=min(TRIED_PER_STEP, len(options)), replace=False)
        best = None
        for k in picks:
            sv, sd = options[int(k)]
            if len(v) + len(sv) > points or sum(dwell) + sum(sd) > budget_t:
                continue
            run = probe(np.array(v + sv), np.array(dwell + sd), readings, initial_V=lo)
            s, p = separation(rivals, base, run, sigma, memo)
            share = len(sv) / points + (sum(sd) / budget_t if np.isfinite(budget_t) else 0.0)
            value = (s * s - score * score) / share
            if best is None or value > best[0]:
                best = (value, sv, sd, s, p)
        if best is None:
            break
        _, sv, sd, score, pairs = best
        v += sv
        dwell += sd
    return Plan(np.round(np.array(v), 4), np.array(dwell), float(score), pairs)


# ----------------------------------------------------------------------------- from a diagnosis


@dataclass(frozen=True)
class Request:
    """Whether a diagnosis asks for a discriminating run: ``between`` the rivals to separate (empty: no
    run is needed, or none can be designed) and ``reason`` why, in one clause."""

    between: tuple[str, ...]
    reason: str


def request(diagnosis) -> Request:
    """The rivals a discriminating run should separate, from a :class:`~identify.diagnosis.Diagnosis`.

    * ``ambiguous``: the rivals the verdict names (at most :data:`RIVALS`);
    * ``unexplained`` with candidates that each close part of the gap: the
      best :data:`RIVALS_UNEXPLAINED` of them (each improving the held-out
      error), and the base model alone when only one does;
    * ``cannot_tell``: the best two candidates that improve the held-out
      error, if any;
    * ``explained`` by one effect with a runner-up whose held-out shrink is
      inside the named one's interval: those two.

    ``resolution`` is never a rival: a finer grid is told apart by an
    identification run on that grid, not by a check run.
    """
    v = diagnosis.verdict
    improving = [c for c in diagnosis.candidates
                 if c.shrink > 0 and isinstance(c.fitted, Effect)]  # best first, as the diagnosis ranks them
    names = [c.effect for c in improving]
    if v.status == "ambiguous":
        between = tuple(n for n in (v.rivals or v.contenders) if n in names)[:RIVALS]
        why = f"the verdict is ambiguous between {', '.join(v.rivals or v.contenders)}"
    elif v.status == "unexplained":
        between = tuple(names[:RIVALS_UNEXPLAINED])
        why = "no candidate closes the gap alone"
    elif v.status == "cannot_tell":
        between = tuple(names[:RIVALS])
        why = "the noise floor is not measured"
    elif v.status == "explained" and len(v.effects or (v.effect,)) == 1:
        best = diagnosis.score(v.effect)
        runner = next((c for c in improving if c.effect != v.effect), None)
        if best is None or runner is None or runner.shrink < best.ci[0]:
            return Request((), f"the verdict is clear: {v.effect} improves clearly more than any other candidate")
        between = (v.effect, runner.effect)
        why = f"{runner.effect}'s held-out shrink ({runner.shrink:.2f}) is inside {v.effect}'s interval"
    else:
        return Request((), f"the verdict ({v.status}) is clear")
    if v.status == "unexplained" and len(between) == 1:
        between = (between[0], "none")
    if len(between) < 2:
        return Request((), f"{why}, but fewer than two candidates improve the held-out error: nothing to tell apart")
    return Request(between, why)


def rival_of(diagnosis, name: str, check: Run) -> Rival:
    """``name``'s rival: the base model with the candidate as fitted on the check data (``"none"``: the base
    model alone).  A per-run effect (a drift) predicts the plan with its realisation on ``check`` and
    re-fits its own nuisance terms there."""
    base = diagnosis.base.model
    if name == "none":
        return Rival(name, (base,))
    score = diagnosis.score(name)
    if score is None or not isinstance(score.fitted, Effect):
        raise IdentifyError(f"{name} has no fitted effect to predict a plan with")
    effect, setting = score.fitted, dict(score.setting)
    if not effect.per_run:
        return Rival(name, (replace(base, effects=(effect,)),))

    def nuisance(run: Run, effect: Effect = effect, setting: dict = setting) -> np.ndarray:
        return np.hstack(effect.nuisance_columns(Context.of_model(base, (run,)), setting).values)

    return Rival(name, (replace(base, effects=(as_plan(effect, check.name),)),), nuisance)


def noise_of(diagnosis) -> float | None:
    """The noise of one reading (um) a separation is counted in: the measured one, else the noise floor
    (an upper bound from the fit's residual: a plan is then, if anything, too cautious); None if neither."""
    for s in (diagnosis.measurement_noise_um, diagnosis.noise_floor_um):
        if s is not None and np.isfinite(s) and s > 0:
            return float(s)
    return None


def achieved(rivals: list[Rival], base: PreisachModel, run: Run, sigma: float) -> dict[str, float]:
    """The separation a measured ``run`` achieved between each pair of rivals ``"A|B"`` (noise levels):
    ``sign * sqrt(|RSS_B - RSS_A|) / sigma``, ``RSS_X`` the residual sum of squares of rival ``X`` on the
    run's measured points after re-fitting what it may re-fit there (as in :func:`separation`); positive
    when ``A`` fits better.  When one rival is the truth its expectation is about the predicted
    separation (``S^2 = E[RSS_other - RSS_true]`` up to the noise's degrees of freedom)."""
    rows = np.flatnonzero(np.isfinite(run.outputs))
    y = run.outputs[rows]
    f0 = base.predict(run.inputs)
    rss = {}
    for r in rivals:
        f = r.models[0].predict_run(run)
        cols = _refit_columns(r, f0, f, run)[rows]
        rss[r.name] = _unexplained(y - f[rows], cols) ** 2
    out = {}
    for a, b in combinations(rivals, 2):
        d = rss[b.name] - rss[a.name]
        out[f"{a.name}|{b.name}"] = float(np.sign(d) * np.sqrt(abs(d)) / sigma)
    return out
