"""The diagnosis: base fit, held-out residuals, candidates, scores, verdict -- arrays in, a result out.

:func:`diagnose` fits equation (22) on the identification runs, predicts
the check runs, and asks of the check residual (``model - measured``):

* **where** -- the residual binned by input, branch, time since reversal,
  last step, predicted output and session time (:mod:`~identify.diagnosis.binning`);
* **which** -- every candidate of the library fitted jointly with the base
  model and scored on held-out check blocks (:mod:`~identify.cross_validation`),
  ranked by the held-out improvement with a block-bootstrap interval, and
  the verdict (:mod:`~identify.diagnosis.verdict`);
* **how far** -- baseline held-out RMSE, RMSE with each candidate, shrink
  ``1 - RMSE_with / RMSE_base``, the noise floor (:mod:`~identify.diagnosis.noise`)
  and the share of the excess gap closed.

Problems with the data that do not prevent a diagnosis (check points
outside the identification range, a check run too short for a candidate,
runs on different grids) are listed in :attr:`Diagnosis.warnings` or
:attr:`Diagnosis.not_assessed`; the rest raise :class:`IdentifyError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, Callable

import numpy as np

from ..effects import INPUT, Columns, Context, EffectNotIdentifiable, make_effect
from ..effects.joint import JointFit, context_of, fit_with_effects
from ..errors import IdentifyError, MethodNotApplicable
from ..grid import Grid
from ..runs import Run
from ..threads import blas_threads_for
from ..validation import validate_run
from .base import BaseFit, fit_base, uncertain_directions
from .binning import Binning, bin_residuals
from .candidates import Candidate, library
from .noise import NoiseEstimate, estimate_noise, fit_residual_bound, floor_per_point
from .resolution import MODES as RESOLUTION_MODES, Resolution
from .use_clock import CLOCKS as USE_CLOCKS, UseClocked, is_session_drift
from ..cross_validation import (Blocks, Design, bootstrap_mse, coefficients_without, cross_validate, make_blocks,
                                onehot, predict_at_chosen)
from .verdict import Evidence, Verdict

#: Fraction of the scored range within which an input counts as inside the grid.
RANGE_TOLERANCE = 1e-9
#: A per-run coefficient needs this many blocks of its run to be cross-validated.
MIN_BLOCKS_PER_RUN = 3
#: Bounded effects whose largest plausible signature stays below this fraction of the floor are invisible.
VISIBLE = 0.5
#: A column whose effective part is below this fraction of its raw size counts as absorbed.
ABSORBED = 1e-6
#: Confidence of the reported intervals.
CONFIDENCE = 0.95
#: How many of the base fit's noise amplifications are reported.
MAX_REPORTED_AMPLIFICATION = 5
#: An input effect whose held-out correction is this many noise floors (rms) is linearised again at its fit:
#: at the base model its columns describe a small effect, and a large lag or mean field bends away from them.
RELINEARISE = 3.0


@dataclass(frozen=True)
class DiagnosisSettings:
    """``method`` (and ``method_settings``) of the base fit; ``effects``: the candidate library
    (None: all); ``n_boot`` bootstrap resamples, ``seed`` of the bootstrap; ``keep``: fit and score the
    model with the named effect(s) (:class:`KeptModel`)."""

    method: str = "ls"
    method_settings: dict[str, Any] | None = None
    thermal_term: bool = True
    effects: tuple[str, ...] | None = None
    n_boot: int = 2000
    seed: int = 0
    #: Fit the named effects as ``rig identify --with`` would and score that model (:class:`KeptModel`).
    keep: bool = True


@dataclass(frozen=True)
class CandidateScore:
    """A candidate's held-out score.  ``rmse_um`` held-out RMSE with the candidate; ``shrink``
    ``1 - rmse / baseline``; ``ci`` its interval (:data:`CONFIDENCE`, for the fixed check design,
    see :mod:`~identify.diagnosis.verdict`) and ``ci_block_bootstrap`` the block bootstrap's;
    ``gain_um2`` the MSE reduction and ``z`` over its standard error; ``params`` the fit on all check
    data in physical terms; ``visible`` whether the input design can show the effect at all;
    ``share_closed`` of the excess over the noise floor (None when unknown)."""

    effect: str
    rmse_um: float
    shrink: float
    ci: tuple[float, float]
    gain_um2: float
    z: float
    params: dict[str, Any]
    visible: bool
    note: str
    share_closed: float | None
    ci_block_bootstrap: tuple[float, float] = (float("nan"), float("nan"))
    #: The candidate fitted on all the check data (an :class:`identify.effects.Effect`, or the resolution
    #: candidate): what a discriminating design predicts with.  Not compared, not printed.
    fitted: Any = field(default=None, compare=False, repr=False)
    #: The setting that fit is at.
    setting: dict[str, float] = field(default_factory=dict, compare=False, repr=False)


@dataclass(frozen=True)
class KeptModel:
    """The model ``rig identify --with EFFECT[,...]`` stores for the effects the verdict names, fitted on the
    identification runs alone and judged like any model on the scored check points: ``rmse_um`` held
    out, ``shrink`` ``1 - rmse / fit_only_rmse_um`` against the base model exactly as identified; drifts
    of the check runs re-estimated on held-out blocks (:mod:`identify.effects.nuisance`).  ``error`` says
    why there is none (an effect the identification runs cannot identify), with ``rmse_um`` None."""

    effects: tuple[str, ...]
    rmse_um: float | None
    shrink: float | None
    params: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    error: str | None = None


@dataclass(frozen=True, eq=False)
class CheckPoints:
    """The scored check points, ``(m,)`` each: ``run`` (index into the check runs), ``index`` (point
    of that run), ``measured`` and ``predicted`` (um), ``residual`` (model - measured, um),
    ``floor`` (um, None when unknown), ``features`` for the bins."""

    run: np.ndarray
    index: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    residual: np.ndarray
    floor: np.ndarray | None
    features: dict[str, np.ndarray]


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Everything :func:`diagnose` found (see the module doc)."""

    grid: Grid
    method: str
    base: BaseFit
    fit_runs: tuple[str, ...]
    check_runs: tuple[str, ...]
    baseline_rmse_um: float
    fit_only_rmse_um: float
    amplification: tuple[float, ...]
    recalibrated: int
    baseline_ci: tuple[float, float]
    noise: NoiseEstimate | None
    noise_floor_um: float | None
    measurement_noise_um: float | None
    where: list[Binning]
    candidates: list[CandidateScore]
    not_assessed: list[tuple[str, str]]
    verdict: Verdict
    points: CheckPoints
    residual_after: dict[str, np.ndarray]
    where_after: list[Binning] | None
    warnings: list[str] = field(default_factory=list)
    evidence: Evidence | None = None
    input_unit: str = "V"
    output_unit: str = "um"
    kept: KeptModel | None = None
    #: How :attr:`noise_floor_um` is known: ``measured``, ``bound`` (from the fit's residual) or None.
    floor_kind: str | None = None

    @property
    def chosen(self) -> str | None:
        """The effect whose corrected residual the report shows: the named one, else the best contender."""
        if self.verdict.effect is not None:
            return self.verdict.effect
        return self.verdict.contenders[0] if self.verdict.contenders else None

    def score(self, effect: str) -> CandidateScore | None:
        return next((c for c in self.candidates if c.effect == effect), None)

    def verdict_without(self, effects: list[str] | tuple[str, ...]) -> Verdict:
        """The verdict a library without ``effects`` would have reached (the same held-out scores)."""
        assert self.evidence is not None
        return self.evidence.decide(exclude=tuple(effects))


# ---------------------------------------------------------------- helpers
def _scored_rows(grid: Grid, run: Run, warnings: list[str]) -> np.ndarray:
    rows = run.rows
    tol = RANGE_TOLERANCE * (grid.v_max - grid.v_min)
    v = run.inputs[rows]
    inside = (v >= grid.v_min - tol) & (v <= grid.v_max + tol)
    if not inside.all():
        out = int((~inside).sum())
        u = run.input_unit
        warnings.append(
            f"{run.name}: {out} of {rows.size} measured points lie outside the identification range "
            f"[{grid.v_min:g}, {grid.v_max:g}] {u} (from {v.min():g} to {v.max():g} {u}); they are not scored"
        )
    return rows[inside]


def _features(run: Run, rows: np.ndarray, predicted: np.ndarray) -> dict[str, np.ndarray]:
    h = run.history
    return {
        "input_V": run.inputs[rows],
        "branch": h.branch[rows].astype(float),
        "time_since_reversal_s": h.since_reversal_s[rows],
        "last_step_V": h.last_step_V[rows],
        "predicted_um": predicted[rows],
        "session_time_s": run.t_s[rows],
        **({"reversal_V": h.reversal_V[rows]} if run.by_curves else {}),
    }


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


@dataclass(frozen=True, eq=False)
class _Scored:
    """The check data in the stacked order of the ``m`` scored points: the runs used, their scored rows,
    the base model's regressor rows there ``(m, n)``, its carry-over ``(m, m_fit)`` (identification
    outputs to check predictions), the held-out blocks; the ``measured`` and ``predicted`` outputs and
    the ``gap`` ``measured - predicted`` (what the model misses; the residual reported is ``-gap``), ``(m,)``
    each in um; and the ``features`` the residual is binned by, ``(m,)`` each."""

    runs: tuple[Run, ...]
    rows: tuple[np.ndarray, ...]
    carry: np.ndarray
    blocks: Blocks
    regressor: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    gap: np.ndarray
    features: dict[str, np.ndarray]


@dataclass(frozen=True, eq=False)
class _Reference:
    """What the candidates are judged against: ``residual`` ``(m,)`` (um), the gap less the base fit's
    poorly determined directions ``recal`` ``(m, r)`` re-estimated on held-out check blocks;
    ``amplification`` ``(s,)`` the base fit's noise amplifications, largest first; ``carry_rest``
    ``(m, m_fit)`` the carry-over outside ``recal``."""

    residual: np.ndarray
    recal: np.ndarray
    amplification: np.ndarray
    carry_rest: np.ndarray


@dataclass(frozen=True, eq=False)
class _Floor:
    """The noise floor at the scored check points: ``noise`` the estimate (the bound from the fit's
    residual when none is measured); ``kind`` ``measured``, ``bound`` or None; ``per_point`` ``(m,)`` (um,
    None when unknown) and its rms ``rms_um``; ``estimate`` ``(m,)`` the unmeasured estimate beside a
    bound (else None); ``rse`` the relative standard error of a measured variance (else 0)."""

    noise: NoiseEstimate | None
    kind: str | None
    per_point: np.ndarray | None
    rms_um: float | None
    estimate: np.ndarray | None
    rse: float


@dataclass(frozen=True, eq=False)
class _Assessed:
    """A candidate fitted jointly with the base model: ``after`` ``(m,)`` the gap it leaves on held-out
    blocks (um); ``params``, ``fitted`` and ``setting`` its fit on all the check data; ``visible`` and
    ``note`` (:func:`_visible`); for fitting it beside a second candidate, its effective ``parts`` and
    columns ``cols`` per setting and the settings cross-validation chose, ``full_setting`` on all blocks
    and ``chosen`` ``(B,)`` for each held-out block."""

    cand: Candidate
    after: np.ndarray
    params: dict[str, Any]
    visible: bool
    note: str
    fitted: Any
    setting: dict[str, float]
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
    cols: list[Columns]
    full_setting: int
    chosen: np.ndarray


def _effective(base: BaseFit, scored: _Scored, cols: Columns) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint-fit columns of one setting.

    Returns ``E = C_check - carry C_fit`` ``(m, k)`` at the scored check
    points (the effect minus what the base fit absorbed of it), ``A = (I - H)
    C_fit`` ``(m_fit, k)`` at the identification points (what the base fit
    could not absorb), and the raw columns (check then fit points).
    """
    n_fit = len(base.fit_runs)
    c_fit = np.vstack([cols.values[i][run.rows] for i, run in enumerate(base.fit_runs)])
    c_check = np.vstack([cols.values[n_fit + i][rows] for i, rows in enumerate(scored.rows)])
    return c_check - scored.carry @ c_fit, base.unabsorbed(c_fit), np.vstack([c_check, c_fit])


def _columns(cand: Candidate, ctx: Context, settings: list[dict[str, float]]) -> list[Columns]:
    """``cand``'s columns at each setting, computed once for settings that differ only in the roughness
    weight: ``smoothing`` reaches the columns only as :attr:`Columns.smoothing` (a drift's six weights
    share one set of splines -- for the ambient drift, a secant per spline coefficient)."""
    done: dict[tuple, Columns] = {}
    out = []
    for s in settings:
        key = tuple(sorted((k, v) for k, v in s.items() if k != "smoothing"))
        if key not in done:
            done[key] = cand.columns(ctx, s)
        out.append(replace(done[key], smoothing=float(s.get("smoothing", 0.0))))
    return out


def _shared(cols_list: list[Columns], make: Callable[[Columns], Any]) -> list:
    """``make(cols)`` for each entry of ``cols_list``, computed once for entries that share their column
    values (those :func:`_columns` computed once)."""
    done: dict[int, Any] = {}
    out = []
    for c in cols_list:
        if id(c.values) not in done:
            done[id(c.values)] = make(c)
        out.append(done[id(c.values)])
    return out


def _with_reference(e: np.ndarray, a: np.ndarray, cols: Columns, recal: np.ndarray) -> Design:
    """A candidate's design with the reference's re-estimated directions appended (no fit-run part)."""
    k, r = cols.k, recal.shape[1]
    rough = None
    if cols.roughness is not None:
        rough = np.zeros((k + r, k + r))
        rough[:k, :k] = cols.roughness
    return Design(np.hstack([e, recal]), np.hstack([a, np.zeros((a.shape[0], r))]), rough, cols.smoothing,
                  np.concatenate([np.asarray(cols.nonneg, bool), np.zeros(r, bool)]))


def _pair_design(first: tuple, cols_first: Columns, second: tuple, cols_second: Columns, recal: np.ndarray) -> Design:
    """Two candidates fitted together (each with its own penalty), with the reference's directions once."""
    ea, aa, _ = first
    eb, ab, _ = second
    ka, kb, r = cols_first.k, cols_second.k, recal.shape[1]
    blocks = tuple((offset + np.arange(c.k), np.asarray(c.roughness, float), float(c.smoothing))
                   for c, offset in ((cols_first, 0), (cols_second, ka))
                   if c.roughness is not None and c.smoothing > 0)
    nonneg = np.concatenate([np.asarray(cols_first.nonneg, bool), np.asarray(cols_second.nonneg, bool), np.zeros(r, bool)])
    return Design(np.hstack([ea, eb, recal]), np.hstack([aa, ab, np.zeros((aa.shape[0], r))]), None, 0.0, nonneg,
                  blocks)


def _relinearised(cand: Candidate, base: BaseFit, ctx: Context, scored: _Scored, setting: dict[str, float],
                  cols: Columns, design: Design, gap: np.ndarray, recal: np.ndarray, fit_weight: float) -> np.ndarray:
    """Held-out residuals of an input effect linearised again at its own fit (a large effect, see
    :data:`RELINEARISE`), two-fold so that no block is judged at a point fitted on it.

    The check blocks are split in alternate halves; the effect is fitted on the identification term and
    one half, and at that fit its output change ``d`` (one column, the big step) and its columns there
    (the small steps, unconstrained: they go either way from the fit) are cross-validated like any
    candidate; the predictions of the other half's blocks are kept.  ``(m,)``.
    """
    blocks = scored.blocks
    prediction = np.zeros_like(gap)
    for half in (0, 1):
        mine = np.flatnonzero(np.arange(blocks.count) % 2 == half)
        coef = coefficients_without(design, gap, blocks, mine, base.residual, fit_weight)[: cols.k]
        fitted = cand.with_fit(ctx, setting, coef, cols)
        at = context_of(replace(base.model, effects=(fitted,)), ctx.runs, (fitted,))
        step = fitted.columns(at, setting)
        keep = _in_play(coef, cols, step)
        values = tuple(np.hstack([(p1 - p0)[:, None], v * keep])
                       for p1, p0, v in zip(at.predictions, ctx.predictions, step.values))
        rough = None
        if step.roughness is not None:
            rough = np.zeros((step.k + 1, step.k + 1))
            rough[1:, 1:] = step.roughness
        both = Columns(values, ("fit", *step.labels), (False,) * (step.k + 1), (-1, *step.run_of), rough,
                       step.smoothing)
        e, a, _ = _effective(base, scored, both)
        cv = cross_validate(gap, blocks, [_with_reference(e, a, both, recal)], base.residual, fit_weight)
        rows = np.isin(blocks.index, mine)
        prediction[rows] = cv.prediction[rows]
    return gap - prediction


def _in_play(coef: np.ndarray, cols: Columns, step: Columns) -> np.ndarray:
    """``(k,)`` 1.0 for the step columns a relinearisation keeps, 0.0 for the others: a sign-constrained
    column whose coefficient the fit left at zero, with both its neighbours' (a spectrum's adjacent
    modes), is left out.  Unconstrained, the small steps in modes the fit never used are nearly collinear
    with the big one and with each other: on a lag of fraction 0.002 their cross-validated coefficients
    reached 17 and -35 (fractions) in a 1 s mode no dwell resolves, and the held-out error doubled."""
    keep = np.ones(step.k)
    if step.k != cols.k or step.labels != cols.labels:
        return keep
    used = np.asarray(coef, dtype=float) != 0.0
    near = used.copy()
    near[1:] |= used[:-1]
    near[:-1] |= used[1:]
    constrained = np.asarray(cols.nonneg, dtype=bool)
    keep[constrained & ~near] = 0.0
    return keep


def _assessable(cand: Candidate, cols: Columns, scored: _Scored, n_fit: int) -> str | None:
    """Why ``cand`` cannot be assessed on these check runs, or None."""
    for j, r in enumerate(cols.run_of):
        i = r - n_fit
        if r < 0 or i < 0:
            continue
        per_run = sum(1 for x in cols.run_of if x == r)
        nb, m = scored.blocks.per_run(i), scored.rows[i].size
        if nb < MIN_BLOCKS_PER_RUN or m < 3 * per_run:
            return (f"check run {scored.runs[i].name} has only {m} scored points; its per-run "
                    f"{cand.name} terms need at least {max(MIN_BLOCKS_PER_RUN * 5, 3 * per_run)}")
    return None


def _visible(cand: Candidate, designs: list[np.ndarray], raws: list[np.ndarray], cols: list[Columns],
             floor_rms: float | None, unit: str = "um") -> tuple[bool, str]:
    """Whether the input design can show ``cand`` at all, and a note when it cannot (each setting's
    effective ``designs``, ``raws`` columns and their ``cols``, which may differ in number)."""
    bounds = cand.bounds()
    traced = [
        (label, _rms(e[:, j]))
        for e, raw, c in zip(designs, raws, cols)
        for j, label in enumerate(c.labels)
        if _rms(e[:, j]) > ABSORBED * max(_rms(raw[:, j]), 1e-300)
    ]
    if not traced:
        return False, ("leaves no trace on the check points with this input design "
                       "(absorbed by the base model, or not excited)")
    if floor_rms is None or any(label not in bounds for label, _ in traced):
        return True, ""
    largest = max(size * bounds[label] for label, size in traced)
    if largest < VISIBLE * floor_rms:
        return False, (f"cannot be seen with this input design: at its largest plausible size it would "
                       f"change the check outputs by {largest:.2g} {unit} rms, under half the noise floor")
    return True, ""


# ---------------------------------------------------------------- the stages of the diagnosis
def _run_units(fit_runs: tuple[Run, ...], check_runs: tuple[Run, ...]) -> tuple[str, str]:
    """The ``(input, output)`` units all the runs record, e.g. ``("V", "um")``.  Raises
    :class:`IdentifyError` when there is no check run, two runs share a name, or the units differ."""
    if not check_runs:
        raise IdentifyError("no check run: the diagnosis judges on held-out runs, never on the fitted ones")
    names = [r.name for r in fit_runs + check_runs]
    if len(set(names)) != len(names):
        raise IdentifyError(f"run names must be distinct, got {', '.join(names)}")
    units = {(r.input_unit, r.output_unit) for r in fit_runs + check_runs}
    if len(units) != 1:
        raise IdentifyError("the runs record different units: "
                            + ", ".join(f"{r.name} {r.input_unit} in, {r.output_unit} out" for r in fit_runs + check_runs))
    return units.pop()


def _scored_check_runs(grid: Grid, check_runs: tuple[Run, ...], warnings: list[str]
                       ) -> tuple[tuple[Run, ...], tuple[np.ndarray, ...]]:
    """The check runs with measured points inside the identification range, and those points' indices
    (``(m_i,)`` each); points outside and runs without any are said in ``warnings``.  Raises
    :class:`IdentifyError` when no check point is inside."""
    used, rows = [], []
    for run in check_runs:
        r = _scored_rows(grid, run, warnings)
        if r.size == 0:
            warnings.append(f"{run.name}: no measured point inside the identification range; not used")
            continue
        used.append(run)
        rows.append(r)
    if not used:
        raise IdentifyError("no check point lies inside the identification range; nothing to judge the model on")
    return tuple(used), tuple(rows)


def _held_out_gap(base: BaseFit, fit_runs: tuple[Run, ...], used: tuple[Run, ...], rows: tuple[np.ndarray, ...]
                  ) -> tuple[Context, _Scored]:
    """The base model on the scored check points: the candidates' :class:`Context` (the identification
    runs, then the check runs ``used``) and the check data (:class:`_Scored`), ``m`` points stacked run
    by run, with the gap the model leaves there (um) and the features of each point."""
    n_fit = len(fit_runs)
    ctx = Context.of_model(base.model, fit_runs + used, n_fit)
    # on the check runs the hysterons feel the model's own output, not the measured one: a mean field fed
    # the measured output would predict each held-out block from that block's own readings
    ctx = replace(ctx, feedback=ctx.feedback[:n_fit] + ctx.predictions[n_fit:])
    preds = ctx.predictions[n_fit:]
    regs = np.vstack([base.regressor(run)[r] for run, r in zip(used, rows)])
    measured = np.concatenate([run.outputs[r] for run, r in zip(used, rows)])
    predicted = np.concatenate([p[r] for p, r in zip(preds, rows)])
    features: dict[str, list[np.ndarray]] = {}
    for run, r, p in zip(used, rows, preds):
        for key, value in _features(run, r, p).items():
            features.setdefault(key, []).append(value)
    return ctx, _Scored(used, rows, base.carry_over(regs), make_blocks([r.size for r in rows]), regs, measured,
                        predicted, measured - predicted, {k: np.concatenate(v) for k, v in features.items()})


def _reference(base: BaseFit, scored: _Scored) -> _Reference:
    """The base model with the directions the identification design leaves poorly determined (noise
    amplified > AMPLIFICATION into the check predictions) re-estimated on held-out check blocks, so that
    identification noise carried through them does not pose as an effect."""
    recal, amplification = uncertain_directions(base.carry_factor(scored.regressor))
    if recal.shape[1]:
        residual = scored.gap - cross_validate(scored.gap, scored.blocks, [Design(recal)]).prediction
    else:
        residual = scored.gap
    return _Reference(residual, recal, amplification, scored.carry - recal @ (recal.T @ scored.carry))


def _noise_floor(base: BaseFit, scored: _Scored, reference: _Reference, monitors: list[np.ndarray] | None,
                 warnings: list[str]) -> _Floor:
    """The noise floor of the scored check points (um, ``(m,)``): measured (repeated readings of one
    memory state, ``monitors``), else only bounded by the base fit's residual, else unknown -- the latter
    two said in ``warnings``.  Identification noise carried into the check predictions is included."""
    noise = estimate_noise(base, list(scored.runs), monitors)
    scored_runs = [(run, r.size) for run, r in zip(scored.runs, scored.rows)]
    extra = reference.recal.shape[1] / max(scored.gap.size, 1)
    kind: str | None = "measured" if noise is not None and noise.measured else None
    floor = estimate = None
    rse = 0.0
    if kind == "measured":
        floor = floor_per_point(noise, base, scored_runs, reference.carry_rest, extra=extra)
        rse = noise.relative_se_of_variance
    else:
        bound = fit_residual_bound(base)
        if bound is not None:
            kind = "bound"
            floor = floor_per_point(bound, base, scored_runs, reference.carry_rest, extra=extra)
            if noise is not None:
                estimate = floor_per_point(noise, base, scored_runs, reference.carry_rest, extra=extra)
            noise = noise or bound
            warnings.append("no measured noise floor (no repeated runs, repeated set-points or calibration "
                            "points): the noise is only bounded, from the base fit's residual, so the verdict "
                            "cannot say 'no gap'")
    if floor is None:
        warnings.append("no noise estimate: no repeated runs or set-points, and the base fit leaves no "
                        "residual degree of freedom; bins are judged by their own scatter")
    return _Floor(noise, kind, floor, _rms(floor) if floor is not None else None, estimate, rse)


def _fit_weight(noise: NoiseEstimate | None, fit_runs: tuple[Run, ...], used: tuple[Run, ...]) -> float:
    """The weight of an identification point in the joint fit relative to a check point: the ratio of
    their noise variances, as their numbers of readings say (1 when the runs do not say)."""
    if noise is not None and noise.readings is not None:
        k_fit = {r.readings for r in fit_runs}
        k_check = {r.readings for r in used}
        if len(k_fit) == 1 and len(k_check) == 1 and None not in k_fit | k_check:
            return (noise.sigma_for(k_check.pop()) / noise.sigma_for(k_fit.pop())) ** 2
    return 1.0


def _held_out_candidates(cands: list[Candidate], base: BaseFit, ctx: Context, scored: _Scored,
                         reference: _Reference, floor_rms: float | None, fit_weight: float, unit: str,
                         mapper: Callable | None = None) -> tuple[list[_Assessed], list[tuple[str, str]]]:
    """Every candidate that can be assessed on these runs fitted jointly with the base model and
    scored on held-out check blocks (:func:`_assess`), in library order; and ``(name, why)`` for each
    of the others.

    The candidates are independent: ``mapper`` (a callable like :func:`map`, results in the order of its
    items; the caller's, e.g. one that shares them out between processes) runs :func:`held_out_candidate`
    on each, with everything else bound once (:func:`functools.partial`).  None: one after the other here.
    They are handed out most settings first (a drift's 12 or 24 before a single column), so that
    processes taking them in turn finish together; the outcomes are then put back in library order."""
    job = partial(held_out_candidate, base=base, ctx=ctx, scored=scored, reference=reference, floor_rms=floor_rms,
                  fit_weight=fit_weight, unit=unit)
    order = sorted(range(len(cands)), key=lambda i: -len(cands[i].settings_grid()))
    outcomes = dict(zip(order, (mapper or map)(job, [cands[i] for i in order])))
    assessed, not_assessed = [], []
    for outcome in (outcomes[i] for i in range(len(cands))):
        if isinstance(outcome, _Assessed):
            assessed.append(outcome)
        else:
            not_assessed.append(outcome)
    return assessed, not_assessed


def held_out_candidate(cand: Candidate, *, base: BaseFit, ctx: Context, scored: _Scored, reference: _Reference,
                       floor_rms: float | None, fit_weight: float, unit: str) -> "_Assessed | tuple[str, str]":
    """One candidate of :func:`_held_out_candidates`: assessed (:func:`_assess`), or ``(name, why)`` it cannot
    be.  Depends on nothing but its arguments (a module-level function: it may run in another process)."""
    why_not = cand.applicable(ctx.runs)
    if why_not is not None:
        return cand.name, f"not applicable: {why_not}"
    grid_settings = cand.settings_grid()
    cols_list = _columns(cand, ctx, grid_settings)
    reason = _assessable(cand, cols_list[0], scored, len(base.fit_runs))
    if reason is not None:
        return cand.name, reason
    return _assess(cand, grid_settings, cols_list, base, ctx, scored, reference, floor_rms, fit_weight, unit)


def _assess(cand: Candidate, grid_settings: list[dict[str, float]], cols_list: list[Columns], base: BaseFit,
            ctx: Context, scored: _Scored, reference: _Reference, floor_rms: float | None, fit_weight: float,
            unit: str) -> _Assessed:
    """``cand`` at each of its settings (``cols_list`` its columns there) cross-validated on the check
    blocks for the held-out predictions of the gap (an input effect whose correction is large linearised
    again at its fit, :data:`RELINEARISE`), and fitted on all the check data at the setting chosen."""
    gap = scored.gap
    parts = _shared(cols_list, lambda c: _effective(base, scored, c))
    visible, note = _visible(cand, [p[0] for p in parts], [p[2] for p in parts], cols_list, floor_rms, unit)
    # settings that share their columns (a drift's roughness weights, see _columns) share one design's arrays
    # but for the weight: cross-validation then forms the data part of their normal equations once
    made: dict[int, Design] = {}
    designs = []
    for (e, a, _), c in zip(parts, cols_list):
        if id(c.values) not in made:
            made[id(c.values)] = _with_reference(e, a, c, reference.recal)
        designs.append(replace(made[id(c.values)], smoothing=c.smoothing))
    cv = cross_validate(gap, scored.blocks, designs, base.residual, fit_weight)
    best = cv.full_setting
    after = gap - cv.prediction
    if cand.stage == INPUT and _rms(cv.prediction) >= RELINEARISE * (floor_rms or _rms(gap) / RELINEARISE):
        after = _relinearised(cand, base, ctx, scored, grid_settings[best], cols_list[best], designs[best], gap,
                              reference.recal, fit_weight)
    full = cols_list[best]
    fitted = cand.with_fit(ctx, grid_settings[best], cv.full_coef[: full.k], full)
    return _Assessed(cand, after, fitted.report(ctx.runs), visible, note, fitted, grid_settings[best], parts,
                     cols_list, best, cv.chosen)


def _use_clock_twins(assessed: list[_Assessed], base: BaseFit, ctx: Context, scored: _Scored, reference: _Reference,
                     floor_rms: float | None, fit_weight: float, unit: str, mapper: Callable | None = None
                     ) -> dict[str, _Assessed]:
    """Each session drift assessed, on a clock of use instead of time (:mod:`~identify.diagnosis.use_clock`),
    at the setting its own cross-validation chose, scored like a candidate: ``{drift: its twin assessed}``
    (a twin that cannot be assessed is left out).  Run by ``mapper`` like the candidates."""
    drifts = [a for a in assessed if is_session_drift(a.cand)]
    if not drifts:
        return {}
    job = partial(held_out_candidate, base=base, ctx=ctx, scored=scored, reference=reference, floor_rms=floor_rms,
                  fit_weight=fit_weight, unit=unit)
    outcomes = list((mapper or map)(job, [UseClocked(type(a.cand)(), a.setting) for a in drifts]))
    return {a.cand.name: o for a, o in zip(drifts, outcomes) if isinstance(o, _Assessed)}


def _second_effect(assessed: list[_Assessed], base: BaseFit, ctx: Context, scored: _Scored,
                   reference: _Reference, fit_weight: float) -> tuple[str | None, np.ndarray | None]:
    """A second effect: every other candidate that improves the held-out error on its own (a second must
    stand on its own too, see the verdict) fitted together with the one that improves most.  Returns that
    one's name and the held-out gap each pair leaves, ``(c, m)`` (um; NaN for the candidates not paired),
    or ``(None, None)`` when no candidate was assessed."""
    if not assessed:
        return None, None
    gap = scored.gap
    best = min(assessed, key=lambda a: float(np.mean(a.after ** 2))).cand.name
    by_name = {a.cand.name: a for a in assessed}
    first = by_name[best]
    pairs_after = np.full((len(assessed), gap.size), np.nan)
    mse_reference = float(np.mean(reference.residual**2))
    for i, a in enumerate(assessed):
        if a.cand.name == best or float(np.mean(a.after**2)) >= mse_reference:
            continue
        second = by_name[a.cand.name]
        first_part, first_cols = _first_of_pair(first, second, base, ctx, scored)
        # the second keeps the setting its own cross-validation chose for each held-out block (without
        # that block): a nested search over both settings cost more than all the single candidates
        designs = {s: _pair_design(first_part, first_cols, second.parts[s], second.cols[s], reference.recal)
                   for s in np.unique(second.chosen)}
        pairs_after[i] = gap - predict_at_chosen(gap, scored.blocks, designs, second.chosen, base.residual,
                                                 fit_weight)
    return best, pairs_after


def _first_of_pair(first: _Assessed, second: _Assessed, base: BaseFit, ctx: Context, scored: _Scored
                   ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], Columns]:
    """The first candidate's part of a pair with ``second``: its own columns at its chosen setting -- or,
    when the first is ``resolution`` refitted on a finer grid ``L'``, the model ``rig identify --levels L'
    --with SECOND`` stores (both identified together on the identification runs), as one column.  A finer
    grid fitted without the second effect has already taken part of it into its density (a reversible
    slope as cells along the diagonal), and a coefficient on that grid's column cannot give it back."""
    own = first.parts[first.full_setting], first.cols[first.full_setting]
    if not isinstance(first.cand, Resolution) or isinstance(second.cand, Resolution):
        return own
    setting = first.setting
    if RESOLUTION_MODES[int(setting.get("mode", -1))] != "refit":
        return own
    cols = first.cand.joint_columns(ctx, int(setting["levels"]), second.cand)
    if cols is None:
        return own
    return _effective(base, scored, cols), cols


def _bootstrap(assessed: list[_Assessed], reference: _Reference, blocks: Blocks, settings: DiagnosisSettings
               ) -> np.ndarray:
    """Block-bootstrap mean squared errors ``(n_boot, 1 + c)`` (um^2): the reference, then each candidate's
    held-out gap, on the same resamples."""
    ind = onehot(blocks)
    sse_base = ind @ reference.residual**2
    sse = np.array([ind @ a.after**2 for a in assessed]).reshape(len(assessed), blocks.count)
    return bootstrap_mse(np.vstack([sse_base[None, :], sse]), blocks, settings.n_boot, settings.seed)


def _evidence(assessed: list[_Assessed], reference: _Reference, floor: _Floor, boot: np.ndarray,
              where: list[Binning], pair_with: str | None, pairs_after: np.ndarray | None, blocks: Blocks,
              twins: dict[str, _Assessed] | None = None) -> Evidence:
    """The held-out scores the verdict decides on: reference and candidates' residuals ``(m,)`` and
    ``(c, m)`` (um), the floor, the bootstrap, whether any bin of ``where`` stands out, the pairs, the
    held-out block of every point, and the session drifts' twins on a clock of use."""
    twins = twins or {}
    return Evidence(
        names=tuple(a.cand.name for a in assessed),
        reference=reference.residual,
        after=np.array([a.after for a in assessed]).reshape(len(assessed), reference.residual.size),
        floor=floor.per_point,
        floor_rse=floor.rse,
        boot=boot,
        structure=any(b.significant for w in where for b in w.bins),
        pair_with=pair_with,
        pairs_after=pairs_after,
        within=tuple(getattr(a.cand, "within", None) for a in assessed),
        refinements=tuple(a.cand.name for a in assessed if isinstance(a.cand, Resolution)),
        floor_kind=floor.kind,
        floor_estimate=floor.estimate,
        blocks=blocks.index,
        twins=tuple(twins),
        twin_clocks=tuple(USE_CLOCKS[int(t.setting["clock"])] for t in twins.values()),
        twins_after=np.array([t.after for t in twins.values()]).reshape(len(twins), reference.residual.size),
    )


def _interval(samples: np.ndarray) -> tuple[float, float]:
    """The central :data:`CONFIDENCE` interval of bootstrap ``samples`` ``(n_boot,)``."""
    lo_q, hi_q = (1 - CONFIDENCE) / 2, 1 - (1 - CONFIDENCE) / 2
    return float(np.quantile(samples, lo_q)), float(np.quantile(samples, hi_q))


def _candidate_scores(assessed: list[_Assessed], evidence: Evidence, boot: np.ndarray) -> list[CandidateScore]:
    """Each assessed candidate's :class:`CandidateScore` (RMSE in um, shrink, intervals, MSE gain in
    um^2, share of the excess closed), largest gain first."""
    z, mse_base, mse, shrink = evidence.z(), evidence.mse_base, evidence.mse, evidence.shrink
    excess = evidence.excess()
    shrink_boot = 1.0 - np.sqrt(boot[:, 1:] / boot[:, :1])
    scores = []
    for i, a in enumerate(assessed):
        share = None
        if excess is not None and excess > 0:
            share = float(min((mse_base - mse[i]) / excess, 1.0))
        scores.append(CandidateScore(a.cand.name, float(np.sqrt(mse[i])), float(shrink[i]),
                                     evidence.interval(i, CONFIDENCE), float(mse_base - mse[i]), float(z[i]),
                                     a.params, a.visible, a.note, share, _interval(shrink_boot[:, i]), a.fitted,
                                     a.setting))
    order = np.argsort([-s.gain_um2 for s in scores], kind="stable")
    return [scores[i] for i in order]


def _check_points(scored: _Scored, reference: _Reference, floor: _Floor) -> CheckPoints:
    """The scored check points as reported, the residual ``model - measured`` against the reference."""
    return CheckPoints(
        run=np.concatenate([np.full(r.size, i) for i, r in enumerate(scored.rows)]),
        index=np.concatenate(scored.rows),
        measured=scored.measured,
        predicted=scored.predicted,
        residual=-reference.residual,
        floor=floor.per_point,
        features=scored.features,
    )


def _measurement_noise(noise: NoiseEstimate | None, scored: _Scored) -> float | None:
    """The rms noise of the check points as measured (um, their readings each), None without an estimate."""
    if not noise:
        return None
    return _rms(np.concatenate([np.full(r.size, noise.sigma_for(run.readings))
                                for run, r in zip(scored.runs, scored.rows)]))


def _bin_after_correction(result: Diagnosis, named: tuple[str, ...], names: list[str],
                          pairs_after: np.ndarray | None, unit_names: dict[str, str]) -> None:
    """Bin what is left once corrected (:attr:`Diagnosis.where_after`): with both effects when the verdict
    names two (``names`` the assessed candidates in the order of ``pairs_after``; also added to
    :attr:`Diagnosis.residual_after` as ``first+second``), else with the chosen effect."""
    points, residual_after, chosen = result.points, result.residual_after, result.chosen
    if len(named) == 2 and pairs_after is not None:  # what is left with both named effects
        j = names.index(named[1])
        residual_after["+".join(named)] = -pairs_after[j]
        object.__setattr__(result, "where_after", bin_residuals(points.features, -pairs_after[j], points.floor,
                                                                unit_names))
    elif chosen is not None and chosen in residual_after:
        object.__setattr__(result, "where_after", bin_residuals(points.features, residual_after[chosen],
                                                                points.floor, unit_names))


# ---------------------------------------------------------------- the diagnosis
def diagnose(
    fit_runs: list[Run] | tuple[Run, ...],
    check_runs: list[Run] | tuple[Run, ...],
    grid: Grid,
    settings: DiagnosisSettings | None = None,
    candidates: list[Candidate] | None = None,
    monitors: list[np.ndarray] | None = None,
    *,
    mapper: Callable | None = None,
) -> Diagnosis:
    """Diagnose the gap between equation (22) fitted on ``fit_runs`` and the ``check_runs``.

    ``monitors``: drift-monitor outputs (um, each ``(k,)`` in time order, repeated measurements of one
    memory state, e.g. a FORC file's calibration points), a further estimate of the measurement noise.
    Thousands of small solves and products: on one BLAS thread for a small grid (:mod:`identify.threads`;
    at L = 30 on a loaded two-core machine the library's two threads took 8 times the CPU and 15 times
    the wall time).  ``mapper``: how the independent candidates are run (a callable like :func:`map`, e.g.
    the caller's process pool's; None: one after the other here); the result does not depend on it as long
    as it computes alike (same BLAS threads).
    """
    with blas_threads_for(grid.n_cells + 2):
        return _diagnose(fit_runs, check_runs, grid, settings, candidates, monitors, mapper)


def _diagnose(fit_runs: list[Run] | tuple[Run, ...], check_runs: list[Run] | tuple[Run, ...], grid: Grid,
              settings: DiagnosisSettings | None, candidates: list[Candidate] | None,
              monitors: list[np.ndarray] | None, mapper: Callable | None = None) -> Diagnosis:
    """:func:`diagnose`'s stages."""
    settings = settings or DiagnosisSettings()
    fit_runs, check_runs = tuple(fit_runs), tuple(check_runs)
    input_unit, output_unit = _run_units(fit_runs, check_runs)
    unit_names = {"V": input_unit, "um": output_unit}
    cands = candidates if candidates is not None else library(
        None if settings.effects is None else tuple(n for n in settings.effects if n != Resolution.name))
    warnings: list[str] = []
    base = fit_base(grid, fit_runs, settings.method, thermal_term=settings.thermal_term,
                    settings=settings.method_settings)
    warnings += list(base.notes)
    used, rows = _scored_check_runs(grid, check_runs, warnings)
    if candidates is None and (settings.effects is None or Resolution.name in settings.effects):
        cands = [*cands, Resolution(grid, fit_runs, used, settings.method, base.thermal_term,
                                    settings.method_settings)]
    ctx, scored = _held_out_gap(base, fit_runs, used, rows)
    reference = _reference(base, scored)
    floor = _noise_floor(base, scored, reference, monitors, warnings)
    fit_weight = _fit_weight(floor.noise, fit_runs, used)

    # which: the candidates on held-out blocks, alone and a second beside the best; where: the residual binned
    assessed, not_assessed = _held_out_candidates(cands, base, ctx, scored, reference, floor.rms_um, fit_weight,
                                                  output_unit, mapper)
    twins = _use_clock_twins(assessed, base, ctx, scored, reference, floor.rms_um, fit_weight, output_unit, mapper)
    pair_with, pairs_after = _second_effect(assessed, base, ctx, scored, reference, fit_weight)
    boot = _bootstrap(assessed, reference, scored.blocks, settings)
    where = bin_residuals(scored.features, -reference.residual, floor.per_point if floor.kind == "measured" else None,
                          unit_names)
    evidence = _evidence(assessed, reference, floor, boot, where, pair_with, pairs_after, scored.blocks, twins)
    verdict = with_unassessed(evidence.decide(), not_assessed)
    scores = _candidate_scores(assessed, evidence, boot)

    result = Diagnosis(
        grid=grid,
        method=base.method,
        base=base,
        fit_runs=tuple(r.name for r in fit_runs),
        check_runs=tuple(r.name for r in used),
        baseline_rmse_um=float(np.sqrt(evidence.mse_base)),
        fit_only_rmse_um=_rms(scored.gap),
        amplification=tuple(float(x) for x in reference.amplification[:MAX_REPORTED_AMPLIFICATION]),
        recalibrated=reference.recal.shape[1],
        baseline_ci=_interval(np.sqrt(boot[:, 0])),
        noise=floor.noise,
        noise_floor_um=float(np.sqrt(float(np.mean(floor.per_point**2)))) if floor.per_point is not None else None,
        measurement_noise_um=_measurement_noise(floor.noise, scored),
        where=where,
        candidates=scores,
        not_assessed=not_assessed,
        verdict=verdict,
        points=_check_points(scored, reference, floor),
        residual_after={a.cand.name: -a.after for a in assessed},
        where_after=None,
        warnings=warnings,
        evidence=evidence,
        input_unit=input_unit,
        output_unit=output_unit,
        floor_kind=floor.kind,
    )
    named = verdict_effects(verdict)
    _bin_after_correction(result, named, [a.cand.name for a in assessed], pairs_after, unit_names)
    if named and settings.keep:
        object.__setattr__(result, "kept", _kept(result, grid, fit_runs, used, rows, named, settings,
                                                 base.thermal_term))
    return result


def _kept(result: Diagnosis, grid: Grid, fit_runs: tuple[Run, ...], check_runs: tuple[Run, ...],
          rows: tuple[np.ndarray, ...], named: tuple[str, ...], settings: DiagnosisSettings,
          thermal_term: bool) -> KeptModel:
    """:func:`keep_model` for the named candidates; ``resolution`` is the grid the model is identified on
    (when the identification runs can identify it)."""
    score = result.score(Resolution.name) if Resolution.name in named else None
    if score is not None:
        levels = int(score.params.get("levels", grid.levels))
        if score.params.get("mode") != "refit":
            return KeptModel(named, None, None, {Resolution.name: dict(score.params)},
                             error=f"the identification run(s) hold too few distinct inputs for a grid of {levels} "
                                   f"levels (the finer grid was estimated with the check runs' help): acquire "
                                   f"the identification run on {levels} levels (rig acquire --levels {levels}) "
                                   f"and identify it there")
        grid = Grid(levels, grid.v_min, grid.v_max)
    others = tuple(n for n in named if n != Resolution.name)
    joint = None
    if score is not None and len(others) == 1 and isinstance(score.fitted, Resolution):
        made = score.fitted.refit_with(levels, make_effect(others[0]))  # the second step's fit, when it was one
        joint = made if isinstance(made, JointFit) else None
    kept = keep_model(grid, fit_runs, check_runs, rows, others, settings, thermal_term, result.fit_only_rmse_um,
                      joint)
    if score is None:
        return kept
    return replace(kept, effects=named, params={Resolution.name: {"levels": grid.levels}, **kept.params})


def with_unassessed(verdict: Verdict, not_assessed: list[tuple[str, str]]) -> Verdict:
    """``verdict``, saying which candidates could not be assessed when it leaves the gap open (unexplained,
    ambiguous, cannot tell): the answer may lie among them."""
    if verdict.status not in ("unexplained", "ambiguous", "cannot_tell") or not not_assessed:
        return verdict
    names = tuple(n for n, _ in not_assessed)
    return replace(verdict, reason=f"{verdict.reason}; not assessed: {', '.join(names)} (see not_assessed for why)",
                   unassessed=names)


def verdict_effects(verdict: Verdict) -> tuple[str, ...]:
    """The effects a verdict names (explained), in order."""
    if verdict.status != "explained":
        return ()
    return verdict.effects or ((verdict.effect,) if verdict.effect else ())


def keep_model(grid: Grid, fit_runs: tuple[Run, ...], check_runs: tuple[Run, ...], rows: tuple[np.ndarray, ...],
               names: tuple[str, ...], settings: DiagnosisSettings, thermal_term: bool, base_rmse: float,
               joint: JointFit | None = None) -> KeptModel:
    """:class:`KeptModel` for ``names``: the joint fit on the identification runs (``joint`` when it was
    already made, e.g. by the resolution candidate's second step), scored on ``rows`` of each check run."""
    start = time.perf_counter()
    try:
        if joint is None:
            joint = fit_with_effects(grid, fit_runs, settings.method, [make_effect(n) for n in names],
                                     thermal_term=thermal_term, settings=settings.method_settings)
    except (EffectNotIdentifiable, MethodNotApplicable) as exc:
        return KeptModel(names, None, None, error=str(exc))
    residuals = []
    for run, r in zip(check_runs, rows):
        outputs = np.full(run.n, np.nan)
        outputs[r] = run.outputs[r]
        scored = Run(run.name, run.inputs, outputs, run.t_s, run.dwell_s, run.readings, run.initial_V,
                     run.input_unit, run.output_unit, run.by_curves)
        residuals.append(validate_run(joint.model, scored, check_range=False).residual)
    rmse = _rms(np.concatenate(residuals))
    params = {e.name: e.report(fit_runs) for e in joint.model.effects}
    return KeptModel(names, rmse, 1.0 - rmse / base_rmse if base_rmse > 0 else None, params,
                     time.perf_counter() - start)
