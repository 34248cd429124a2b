"""Plan an identification run within a rig-time budget (``rig acquire --rig-time``).

Rig time is what the paper's method exists to save: the VO2 beam's slow
thermal dynamics make every point wait.  The paper waits out the transient
at every point (467 points x 20 s for L = 30, 2.6 h).  Within a budget a
plan can instead *model* the transient: the ``thermal_lag`` effect
identified jointly (option ``dominant``, :mod:`identify.effects.thermal_lag`)
so that points need not settle.  What still matters:

* the **reversal points** write the memory curve's extremes; a reversal
  reached short of its set-point is modelled too, but every error of the
  lag model there is carried by every later point, so reversals get the
  long dwell the budget allows;
* the **other points** of the damped oscillation get short dwells, drawn
  at random (with the seed) from ``scale * DWELL_SPREAD``: dwells that
  differ are what tells the lag's time constant from its size.

:func:`plan_within` compares the plans of a small family -- the transient
modelled, at several scales of the short dwells (the rest of the budget to
the reversals), and the transient waited out (one dwell everywhere, no lag
in the model) -- by their **expected error on a held-out run**: for each
time constant of a prior (:data:`PRIOR_TIME_CONSTANTS_S`, the operator does
not know it), a reference device (``reference``, equation (22) on the
grid) is simulated through a first-order lag of that time constant, with
noise, over the plan; the model the plan's recipe would fit is solved (the
lag's time constant taken as found: its scan is not re-run here), and its
error predicting a quasi-static random check run is taken, normalised by
the reference's output range.  The plan with the smallest mean log error
over the prior is chosen.  These are a model's expectations on a reference
device, not a promise: the benchmark (``benchmarks/rig_time.py``) measures
plans on devices written without this module.

Readings: ``readings`` per point (K) when given.  Otherwise one reading a
point where the transient is modelled: readings taken while the film
still moves average a moving signal through the hysteresis, a smear the lag
model does not describe (on the tuning devices one reading beat four and
eight: 0.00044 against 0.00055 and 0.00079 on the simulated device,
tau = 3 s, a tenth of the paper's rig time).  Where the transient is waited
out, the largest of :data:`READINGS_CHOICES` whose reading time stays
within :data:`READING_SHARE` of the budget (each reading costs
``reading_s``).

The physical limit: a model of N unknowns (cells, bias, thermal term)
needs N independent readings, each costing at least the sensor's
averaging time and the heater's response (:func:`least_budget_s`: N points
at :data:`MIN_DWELL_S` plus one reading each); below that no plan exists.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .acquisition_plan import reversal_points
from .errors import IdentifyError
from .excitation import Excitation
from .effects.thermal_lag import lagged
from .grid import Grid
from .methods.nnls import nnls_free
from .model import PreisachModel
from .regressor import regressor_matrix
from .runs import Run

#: Thermal time constants (s) the plan must work for, log-spaced over what VO2 beams show.
PRIOR_TIME_CONSTANTS_S = (0.5, 1.5, 5.0, 15.0)
#: Ratios of the short dwells (drawn at random per point), times the plan's scale.
DWELL_SPREAD = (0.2, 0.5, 1.0)
#: Scales (s) of the short dwells the planner may try.
SCALES_S = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
#: How many of them it tries: the largest the budget allows (shorter ones starve nothing but the lag's
#: identification; this keeps planning within its 2 s).
SCALES_TRIED = 3
#: Shortest dwell the rig can hold (s): the heater's electrical response plus a set-point write.
MIN_DWELL_S = 0.1
#: Readings per point the planner may choose (without ``readings``).
READINGS_CHOICES = (1, 2, 4, 8)
#: Largest share of the budget the readings may take when the planner chooses K.
READING_SHARE = 0.05
#: Points of each quasi-static random check run the expected error is taken on.
CHECK_POINTS = 200
#: How many such check runs (seeds): one random run's reversals visit too few cells to judge a plan by.
CHECK_RUNS = 4
#: The effects a plan that models the transient records for ``rig identify``.
LAG_EFFECTS = ("thermal_lag:dominant",)


@dataclass(frozen=True)
class Candidate:
    """One plan of the family: ``kind`` "model" (transient modelled) or "wait" (waited out); ``scale_s``
    the short dwells' scale (model) or the one dwell (wait); ``expected_nrmse`` per prior time constant."""

    kind: str
    scale_s: float
    reversal_dwell_s: float
    rig_time_s: float
    expected_nrmse: dict[float, float]

    @property
    def score(self) -> float:
        """Mean log expected nRMSE over the prior (smaller is better)."""
        return float(np.mean(np.log(list(self.expected_nrmse.values()))))

    def as_dict(self) -> dict:
        return {"kind": self.kind, "scale_s": self.scale_s, "reversal_dwell_s": self.reversal_dwell_s,
                "rig_time_s": self.rig_time_s,
                "expected_nrmse": {f"{t:g}": v for t, v in self.expected_nrmse.items()}}


@dataclass(frozen=True)
class TimedPlan:
    """The chosen plan: the damped oscillation's ``inputs`` (V, ``(n,)``), each point's ``dwell_s``
    (s, ``(n,)``), ``readings`` per point, the ``effects`` ``rig identify`` should fit (``--with``
    spellings), its ``rig_time_s`` (s, dwells plus readings), and the family it was chosen from."""

    inputs: np.ndarray
    dwell_s: np.ndarray
    readings: int
    effects: tuple[str, ...]
    rig_time_s: float
    budget_s: float
    chosen: Candidate
    candidates: tuple[Candidate, ...] = field(default=())

    @property
    def n_points(self) -> int:
        return int(self.inputs.size)

    def as_dict(self) -> dict:
        """JSON-friendly summary (no per-point arrays)."""
        return {"budget_s": self.budget_s, "rig_time_s": self.rig_time_s, "points": self.n_points,
                "readings": self.readings, "effects": list(self.effects), "kind": self.chosen.kind,
                "scale_s": self.chosen.scale_s, "reversal_dwell_s": self.chosen.reversal_dwell_s,
                "expected_nrmse": {f"{t:g}": v for t, v in self.chosen.expected_nrmse.items()},
                "candidates": [c.as_dict() for c in self.candidates]}


def least_budget_s(grid: Grid, thermal_term: bool = True, reading_s: float = 0.0) -> float:
    """The least rig time (s) any plan on ``grid`` needs: every point of the damped oscillation (one per
    unknown) at :data:`MIN_DWELL_S` with one reading of ``reading_s``."""
    n = Excitation.damped(grid, thermal_term).inputs.size
    return n * (MIN_DWELL_S + reading_s)


def _expected(grid: Grid, ref: np.ndarray, check: np.ndarray, span: float, inputs: np.ndarray,
              dwell_s: np.ndarray, nominal: np.ndarray | None, tau: float, noise: float,
              rng: np.random.Generator, thermal_term: bool) -> float:
    """Expected check nRMSE of one plan on the reference device with time constant ``tau``; ``nominal``:
    the regressor of the set-points themselves, for a plan that fits no lag (None: the lag is modelled)."""
    # the reference device through a first-order power-driven lag: the whole rise in one mode, from rest at 0 V
    x = lagged(Run("plan", inputs, np.zeros(inputs.size), np.cumsum(dwell_s), dwell_s), tau, 1.0, drive="power")
    a = regressor_matrix(grid, x, thermal_term)
    y = a @ ref + noise * rng.standard_normal(inputs.size)
    w = nnls_free(a if nominal is None else nominal, y, grid.n_cells)[0]  # the paper's ls: cells >= 0
    err = check @ (w - ref)
    return max(float(np.sqrt(np.mean(err * err))) / span, 1e-12)


def plan_within(grid: Grid, budget_s: float, reference: PreisachModel, *, thermal_term: bool = True,
                readings: int | None = None, reading_s: float = 0.0, noise_um: float = 0.01, seed: int = 0,
                taus_s: tuple[float, ...] = PRIOR_TIME_CONSTANTS_S) -> TimedPlan:
    """The plan of the damped oscillation on ``grid`` within ``budget_s`` seconds of rig time that
    minimises the expected held-out error (see the module docstring).

    ``reference``: the device the expectation is taken on (its density on ``grid``, bias and thermal
    term); ``noise_um``: rms of one reading (um); ``reading_s``: the time one reading takes (s);
    ``readings``: K per point (None: chosen); ``seed``: the short dwells' draw and the simulated noise.
    Raises :class:`IdentifyError` for a budget below :func:`least_budget_s`, naming it.
    """
    if not (math.isfinite(budget_s) and budget_s > 0):
        raise IdentifyError(f"the rig-time budget must be a positive number of seconds, got {budget_s}")
    if reference.grid.n_cells != grid.n_cells:
        raise IdentifyError("the reference device must be on the plan's grid")
    inputs = Excitation.damped(grid, thermal_term).inputs
    n = inputs.size
    least = least_budget_s(grid, thermal_term, reading_s)
    if budget_s < least:
        raise IdentifyError(f"a rig time of {budget_s:g} s cannot identify L = {grid.levels}: its {n} unknowns need "
                            f"{n} points of at least {MIN_DWELL_S:g} s each; the least budget is {least:.0f} s")
    if readings is None:
        fits = [k for k in READINGS_CHOICES if n * k * reading_s <= READING_SHARE * budget_s]
        k_model, k_wait = 1, (fits[-1] if fits else 1)
    else:
        k_model = k_wait = int(readings)
    if budget_s - n * k_model * reading_s < n * MIN_DWELL_S:
        raise IdentifyError(f"{k_model} readings of {reading_s:g} s at each of {n} points leave too little of "
                            f"{budget_s:g} s for the dwells; the least budget is "
                            f"{n * (MIN_DWELL_S + k_model * reading_s):.0f} s")
    rev = reversal_points(inputs)
    draw = np.random.default_rng(seed).choice(len(DWELL_SPREAD), size=n)
    spread = np.asarray(DWELL_SPREAD)[draw]
    ref = reference.parameters(thermal_term)
    check = np.vstack([regressor_matrix(grid, Excitation.random(grid, CHECK_POINTS, seed + j).inputs, thermal_term)
                       for j in range(CHECK_RUNS)])
    span = max(float(np.ptp(check @ ref)), 1e-300)

    schedules: list[tuple[str, float, float, np.ndarray, int]] = []
    dwell_budget = budget_s - n * k_model * reading_s
    for scale in SCALES_S:
        dw = np.maximum(scale * spread, MIN_DWELL_S)
        rest = dwell_budget - float(dw[~rev].sum())
        d_rev = rest / max(int(rev.sum()), 1)
        if d_rev < scale * max(DWELL_SPREAD):
            continue  # reversals at least as long as any other point
        dw = dw.copy()
        dw[rev] = d_rev
        schedules.append(("model", scale, d_rev, dw, k_model))
    schedules = schedules[-SCALES_TRIED:]
    one = (budget_s - n * k_wait * reading_s) / n
    if one >= MIN_DWELL_S:
        schedules.append(("wait", one, one, np.full(n, one), k_wait))

    nominal = regressor_matrix(grid, inputs, thermal_term)
    candidates = []
    for kind, scale, d_rev, dw, k in schedules:
        rng = np.random.default_rng(seed)
        expected = {float(t): _expected(grid, ref, check, span, inputs, dw, None if kind == "model" else nominal,
                                        float(t), noise_um / math.sqrt(k), rng, thermal_term) for t in taus_s}
        candidates.append(Candidate(kind, float(scale), float(d_rev), float(dw.sum() + n * k * reading_s), expected))
    best = min(range(len(candidates)), key=lambda i: candidates[i].score)
    kind, _, _, dw, readings = schedules[best]
    chosen = candidates[best]
    return TimedPlan(inputs=inputs, dwell_s=dw, readings=int(readings),
                     effects=LAG_EFFECTS if kind == "model" else (), rig_time_s=chosen.rig_time_s,
                     budget_s=float(budget_s), chosen=chosen, candidates=tuple(candidates))
