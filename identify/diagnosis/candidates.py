"""The candidate library: each unmodelled effect as an augmentation of the equation (22) model.

A candidate turns what a session records -- the inputs, the time stamps
and dwells, the base model's predictions -- into *columns*: how the output
would change per unit of each of its coefficients, at every point of every
run (identification runs first, then check runs).  A candidate may have a
few nonlinear settings (a time constant) on a small grid; its coefficients
enter linearly.  :mod:`identify.diagnosis.engine` fits the coefficients
jointly with the base model and scores them on held-out check data.

Coefficients are either **structural** -- one physical constant of the
device, shared by every run (a thermal time constant's weight, a creep
amplitude) -- or **per-run nuisance** -- something that differs from one
run to the next (a drift), whose columns are zero outside their run.

These forms are written from the session's point of view and on purpose
differ from the simulated device's physics (:mod:`drivers.sim.builtin_effects`):

=======================  =================================================  ==================================
effect                   candidate (this module)                            simulated device
=======================  =================================================  ==================================
``thermal_lag``          exponential blend of the previous and the current  a slow thermal mode of the
                         *input in volts* over each point's dwell; weight    temperature rise (K, ~ v^2),
                         = lagging fraction                                  first-order ODE in device time
``baseline_drift``       per-run polynomial of session time (um)            sum of random sinusoids (PSD V)
``ambient_drift``        per-run polynomial of time times the base model's  random ambient temperature (K)
                         sensitivity to a uniform input shift (V)           through the sqrt voltage map
``joule_power``          ``c v^2`` on the set-point (V^2)                   um per K of the lagged rise
``creep``                exponential kernel after each reversal, weight per stretched exponential
                         volt of the excursion                              (exponent 0.5)
``sensor_nonlinearity``  quadratic and cubic terms in the base model's      tanh saturation in PSD volts
                         predicted deflection (um)
=======================  =================================================  ==================================
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..model import PreisachModel
from .base import BaseFit
from ..runs import Run

#: Knot spacing (s) of the drift candidates' cubic splines in session time (a penalised spline:
#: the roughness penalty, chosen by cross-validation, decides how wiggly the drift may be).
DRIFT_KNOT_S = 1200.0
#: Weights of the drift splines' roughness penalty tried (relative to the data): from as strong as the
#: data to nearly a straight line per run.  Never none: an unpenalised spline coefficient that the
#: training blocks hardly see (the time window of the held-out block, where only that block's points
#: are in the transition) extrapolates wildly into the held-out block.
DRIFT_SMOOTHING = (1.0, 10.0, 100.0, 1000.0)
#: Degree of the drift splines.
DRIFT_SPLINE_DEGREE = 3
#: Time constants tried for the thermal lag (s): from a fast beam to a slow package.
LAG_TIME_CONSTANTS_S = tuple(float(x) for x in np.geomspace(0.5, 60.0, 12))
#: Relaxation times of creep's kernel (s): a non-negative mixture of these exponentials (a relaxation
#: spectrum, or Prony series) approximates any completely monotone kernel over seconds to an hour.
CREEP_TIME_CONSTANTS_S = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)
#: Largest plausible lagging fraction of the temperature rise (a whole rise arriving late).
MAX_LAG_FRACTION = 1.0
#: Lagging fraction at which the thermal-lag column is taken (a secant of the model's response).
LAG_STEP = 0.05


@dataclass(frozen=True, eq=False)
class Context:
    """What candidates may use.  ``runs`` lists the identification runs first, then the check runs;
    ``predictions[i]`` ``(n_i,)`` is the base model's output (um) at every point of ``runs[i]``;
    ``output_centre``/``output_half_range`` (um) describe the identification outputs."""

    base: BaseFit
    runs: tuple[Run, ...]
    predictions: tuple[np.ndarray, ...]
    output_centre: float
    output_half_range: float

    @classmethod
    def build(cls, base: BaseFit, runs: tuple[Run, ...]) -> "Context":
        lo, hi = float(np.min(base.measured)), float(np.max(base.measured))
        preds = tuple(base.predict(r) for r in runs)
        return cls(base, tuple(runs), preds, 0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12))


@dataclass(frozen=True, eq=False)
class Columns:
    """A candidate's augmentation for one setting.

    ``values[i]`` ``(n_i, k)``: the output change (um) per unit of each
    coefficient at every point of run ``i``; ``labels`` ``(k,)`` name the
    coefficients; ``nonneg`` ``(k,)`` marks coefficients that are >= 0 by
    their physics; ``run_of`` ``(k,)`` is the index of the run a per-run
    coefficient belongs to, ``-1`` for a structural one.  ``roughness``
    ``(k, k)`` (or None) is a penalty on the coefficients, applied with
    weight ``smoothing`` (see :class:`identify.diagnosis.scoring.Design`).
    """

    values: tuple[np.ndarray, ...]
    labels: tuple[str, ...]
    nonneg: tuple[bool, ...]
    run_of: tuple[int, ...]
    roughness: np.ndarray | None = None
    smoothing: float = 0.0

    @property
    def k(self) -> int:
        return len(self.labels)


class Candidate(ABC):
    """One effect's augmentation (see the module doc)."""

    #: The effect's name (the issue's names, used in every output).
    name: ClassVar[str]
    #: One line for reports.
    summary: ClassVar[str]

    def settings_grid(self) -> list[dict[str, float]]:
        """The nonlinear settings to try (each a dict); ``[{}]`` when there are none."""
        return [{}]

    @abstractmethod
    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """The columns for one setting."""

    def params(self, ctx: Context, setting: dict[str, float], coef: dict[str, float]) -> dict[str, Any]:
        """The fitted effect in physical terms (JSON-safe), from the setting and the coefficients."""
        return {**setting, **coef}

    def bounds(self) -> dict[str, float]:
        """Largest plausible ``|coefficient|`` by label, where physics bounds it (for visibility)."""
        return {}

    def applicable(self, ctx: Context) -> str | None:
        """Why the effect cannot act on these runs at all (None: it can).  A candidate that needs
        what the runs do not record (dwell times, time stamps, a heater voltage as the input) is
        reported as not applicable instead of being scored."""
        return None


def _needs_heater(ctx: Context) -> str | None:
    """Not applicable unless the input is a heater voltage (V): the effect is heater physics."""
    units = {r.input_unit for r in ctx.runs}
    if units != {"V"}:
        return (f"it is heater physics (the input as a heater voltage), and these runs' input is in "
                f"{', '.join(sorted(units))}")
    return None


def _needs_time(ctx: Context) -> str | None:
    """Not applicable when a run's time stamps carry no information."""
    untimed = [r.name for r in ctx.runs if not r.timed]
    if untimed:
        return f"it acts over time, and {', '.join(untimed)} record(s) no time (all time stamps equal)"
    return None


# ---------------------------------------------------------------- helpers
def drift_knots(run: Run) -> np.ndarray | None:
    """The knots of :func:`drift_basis` (None when the run's measured points share one time)."""
    tm = run.t_s[run.rows]
    lo, hi = float(tm.min()), float(tm.max())
    k = DRIFT_SPLINE_DEGREE
    if hi <= lo:
        return None
    inner = np.linspace(lo, hi, int((hi - lo) // DRIFT_KNOT_S) + 2)
    return np.concatenate([[lo] * k, inner, [hi] * k])


def drift_basis(run: Run) -> np.ndarray:
    """Cubic B-splines of session time with knots every :data:`DRIFT_KNOT_S`, ``(n, d)``.

    The knots span the run's measured points (times outside are clamped to
    them); the functions add up to one, so the basis holds a constant offset.
    """
    knots = drift_knots(run)
    if knots is None:
        return np.ones((run.n, 1))
    return _spline_at(knots, run.t_s)


def _spline_at(knots: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    from scipy.interpolate import BSpline

    return BSpline.design_matrix(np.clip(t_s, knots[0], knots[-1]), knots, DRIFT_SPLINE_DEGREE).toarray()


def drift_at(run_params: dict[str, Any], t_s: np.ndarray) -> np.ndarray:
    """A fitted drift (one run's entry of a drift candidate's ``params["runs"]``) at times ``t_s``
    ``(k,)`` (s), in the candidate's unit; constant beyond the run's measured times."""
    coef = np.asarray(run_params["coefficients"], dtype=float)
    knots = run_params.get("knots_s")
    t = np.asarray(t_s, dtype=float)
    if knots is None:
        return np.full(t.shape, coef[0])
    return _spline_at(np.asarray(knots, dtype=float), t) @ coef


def _per_run(ctx: Context, block: list[np.ndarray], what: str, smoothing: float = 0.0) -> Columns:
    """Per-run nuisance columns: run ``i`` gets ``block[i]`` ``(n_i, d_i)`` and zeros elsewhere;
    the roughness penalty is the squared second differences of each run's coefficients."""
    offsets = np.cumsum([0] + [b.shape[1] for b in block])
    k = int(offsets[-1])
    values, labels, run_of = [], [], []
    for i, (run, b) in enumerate(zip(ctx.runs, block)):
        v = np.zeros((run.n, k))
        v[:, offsets[i]:offsets[i + 1]] = b
        values.append(v)
        labels += [f"{run.name}:{what}{j}" for j in range(b.shape[1])]
        run_of += [i] * b.shape[1]
    rough = np.zeros((k, k))
    for i, b in enumerate(block):
        d = b.shape[1]
        if d >= 3:
            diff = np.diff(np.eye(d), n=2, axis=0)
            rough[offsets[i]:offsets[i + 1], offsets[i]:offsets[i + 1]] = diff.T @ diff
    return Columns(tuple(values), tuple(labels), (False,) * k, tuple(run_of), rough, smoothing)


def _drift_params(ctx: Context, cols: Columns, coef: dict[str, float], unit: str) -> dict[str, Any]:
    """Each run's fitted drift in physical terms: rms, range over the run and its end-to-end change."""
    out: dict[str, Any] = {}
    beta = np.array([coef[label] for label in cols.labels])
    for i, run in enumerate(ctx.runs):
        mine = np.array([r == i for r in cols.run_of])
        drift = (drift_basis(run) @ beta[mine])[run.rows]
        knots = drift_knots(run)
        out[run.name] = {
            f"rms_{unit}": float(np.sqrt(np.mean((drift - drift.mean()) ** 2))),
            f"range_{unit}": float(np.ptp(drift)),
            f"change_{unit}": float(drift[-1] - drift[0]),
            "knots_s": None if knots is None else [float(x) for x in knots],
            "coefficients": [float(x) for x in beta[mine]],
        }
    return {"runs": out}


# ---------------------------------------------------------------- the candidates
class ThermalLagCandidate(Candidate):
    """Each point's input lags in heater power: ``x_k^2 = v_k^2 + (x_{k-1}^2 - v_k^2) exp(-dwell_k / tau)``.

    A resistive heater heats in proportion to ``v^2``, and a thermal lag
    relaxes the temperature, so the lag is a blend of squared voltages (a
    blend of volts would make heating and cooling lag alike, which they do
    not).  The recursion runs over the points as recorded, each with its
    own dwell.  A fraction ``f`` of the heating lags: the input is
    ``sqrt(v^2 + f (x^2 - v^2))``.  The column is the derivative of the base
    model's output with respect to ``f`` (a secant at ``f =``
    :data:`LAG_STEP`; the memory curve sees the lagged extremes); the
    coefficient is ``f``, >= 0.
    """

    name = "thermal_lag"
    summary = "the dwell is too short for a thermal time constant: the beam is measured short of its set-point"

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"time_constant_s": tau} for tau in LAG_TIME_CONSTANTS_S]

    @staticmethod
    def lagged_inputs(run: Run, tau: float) -> np.ndarray:
        """The lagged inputs (V), ``(n,)``; an unknown dwell counts as fully settled."""
        d = np.where(np.isfinite(run.dwell_s), run.dwell_s, np.inf)
        keep = np.exp(-np.clip(d, 0.0, None) / tau)
        power = run.inputs**2
        x = np.empty(run.n)
        prev = run.initial_V**2
        for k, (p, a) in enumerate(zip(power, keep)):
            prev = p + (prev - p) * a
            x[k] = prev
        return np.sqrt(x)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        tau = setting["time_constant_s"]
        values = []
        model = ctx.base.model
        scale = ctx.base.grid.v_max - ctx.base.grid.v_min
        for run, pred in zip(ctx.runs, ctx.predictions):
            lagged = self.lagged_inputs(run, tau)
            if np.max(np.abs(lagged - np.abs(run.inputs))) <= 1e-12 * scale:
                values.append(np.zeros((run.n, 1)))
                continue
            power = run.inputs**2
            x = np.sqrt(power + LAG_STEP * (lagged**2 - power))
            values.append(((model.predict(x) - pred) / LAG_STEP)[:, None])
        return Columns(tuple(values), ("fraction",), (True,), (-1,))

    def bounds(self) -> dict[str, float]:
        return {"fraction": MAX_LAG_FRACTION}

    def applicable(self, ctx: Context) -> str | None:
        heater = _needs_heater(ctx)
        if heater is not None:
            return heater
        if not any(r.has_dwell for r in ctx.runs):
            return "no run records its dwell (set-point to readings), so there is nothing for a lag to act over"
        return None


class _DriftCandidate(Candidate):
    """A per-run drift: a penalised cubic spline of session time per run (the penalty's weight is
    the setting), reported in :attr:`unit` per run."""

    unit: ClassVar[str]

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"smoothing": w} for w in DRIFT_SMOOTHING]

    def params(self, ctx, setting, coef):
        cols = _per_run(ctx, [drift_basis(r) for r in ctx.runs], "spline")
        return _drift_params(ctx, cols, coef, self.unit)

    def applicable(self, ctx: Context) -> str | None:
        return _needs_time(ctx)


class BaselineDriftCandidate(_DriftCandidate):
    """The output zero moves: a smooth function of session time per run (um, cubic splines)."""

    name = "baseline_drift"
    summary = "the sensor zero drifts over session time (laser pointing, mechanics)"
    unit = "um"

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        return _per_run(ctx, [drift_basis(r) for r in ctx.runs], "spline", setting["smoothing"])


class AmbientDriftCandidate(_DriftCandidate):
    """The input of the memory curve shifts with the room temperature: a smooth function of session
    time per run, linearised.

    The beam's temperature rise is Joule heating, ``~ v^2``; a room
    temperature change adds to it, so the input the memory curve sees is
    ``sqrt(v^2 + d(t)) ~ v + d(t) / (2 v)``, ``d`` in V^2 (a temperature in
    units of the heater's kelvin per V^2).  A shift of a run's whole input
    history changes the Preisach part of the output by ``J shift``, ``J``
    the base model's sensitivity (central difference over half a cell); the
    thermal term is not shifted (the room moves the transition, not the
    heater).  ``d(t)`` is a penalised cubic spline per run.
    """

    name = "ambient_drift"
    summary = "the room temperature drifts, shifting where the transition happens (on the input)"
    unit = "V2"

    @staticmethod
    def sensitivity(ctx: Context, run: Run) -> np.ndarray:
        """``J / (2 v)`` (um/V^2) at every point of ``run``, ``(n,)``: the output change per V^2 of ``d``."""
        base = ctx.base
        phase = PreisachModel(base.grid, base.model.density)
        delta = 0.5 * base.grid.step
        j = (phase.predict(run.inputs + delta) - phase.predict(run.inputs - delta)) / (2.0 * delta)
        v_low = 0.05 * (base.grid.v_max - base.grid.v_min)
        return j / (2.0 * np.maximum(np.abs(run.inputs), v_low))

    def applicable(self, ctx: Context) -> str | None:
        return _needs_heater(ctx) or _needs_time(ctx)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        blocks = [self.sensitivity(ctx, r)[:, None] * drift_basis(r) for r in ctx.runs]
        return _per_run(ctx, blocks, "spline", setting["smoothing"])


class JoulePowerCandidate(Candidate):
    """A thermal term in heater power: ``c_p v^2`` on the set-points (um/V^2), besides ``c_d v``."""

    name = "joule_power"
    summary = "the thermal-expansion term follows heater power (v^2), not voltage"

    def applicable(self, ctx: Context) -> str | None:
        return _needs_heater(ctx)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        return Columns(tuple((r.inputs**2)[:, None] for r in ctx.runs), ("um_per_V2",), (False,), (-1,))


class CreepCandidate(Candidate):
    """After each reversal the output is offset by ``E_r K(t - t_r)`` and relaxes (um).

    ``E_r`` is the excursion (V) that ended at the reversal, ``t_r`` the
    time the input turned back; transients add up.  The kernel is a
    relaxation spectrum: ``K(t) = s sum_j a_j exp(-t / tau_j)`` with
    ``a_j >= 0`` over :data:`CREEP_TIME_CONSTANTS_S` and one sign ``s``
    (chosen by cross-validation like a setting), so it decays monotonically
    whatever its shape.
    """

    name = "creep"
    summary = "the deflection relaxes slowly after each reversal"

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"sign": 1.0}, {"sign": -1.0}]

    def applicable(self, ctx: Context) -> str | None:
        return _needs_time(ctx)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        taus = np.asarray(CREEP_TIME_CONSTANTS_S)
        values = []
        for run in ctx.runs:
            h = run.history
            after = h.after_turn()
            dt = np.where(after, run.t_s[:, None] - h.turn_t[None, :], 0.0)
            cols = [(np.where(after, np.exp(-dt / tau), 0.0) @ h.excursion_V) for tau in taus]
            values.append(setting["sign"] * np.stack(cols, axis=1))
        labels = tuple(f"um_per_V_at_{tau:g}s" for tau in taus)
        return Columns(tuple(values), labels, (True,) * taus.size, (-1,) * taus.size)

    def params(self, ctx, setting, coef):
        weights = {k: setting["sign"] * v for k, v in coef.items()}
        total = sum(weights.values())
        mean_tau = (sum(abs(w) * t for w, t in zip(weights.values(), CREEP_TIME_CONSTANTS_S))
                    / max(sum(abs(w) for w in weights.values()), 1e-300))
        return {"um_per_V": total, "mean_time_constant_s": mean_tau, "spectrum_um_per_V": weights}


class SensorNonlinearityCandidate(Candidate):
    """The reading is ``u + a z^2 + b z^3``, ``z`` the predicted deflection scaled to [-1, 1] over
    the identification outputs (``a``, ``b`` in um)."""

    name = "sensor_nonlinearity"
    summary = "the sensor reading is a mildly nonlinear, saturating function of the deflection"

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        values = []
        for pred in ctx.predictions:
            z = (pred - ctx.output_centre) / ctx.output_half_range
            values.append(np.stack([z**2, z**3], axis=1))
        return Columns(tuple(values), ("quadratic_um", "cubic_um"), (False, False), (-1, -1))

    def params(self, ctx, setting, coef):
        return {**coef, "centre_um": ctx.output_centre, "half_range_um": ctx.output_half_range}


#: The library, by name, in the issue's order.
CANDIDATES: dict[str, type[Candidate]] = {
    cls.name: cls
    for cls in (
        ThermalLagCandidate,
        BaselineDriftCandidate,
        AmbientDriftCandidate,
        JoulePowerCandidate,
        CreepCandidate,
        SensorNonlinearityCandidate,
    )
}


def library(names: list[str] | tuple[str, ...] | None = None) -> list[Candidate]:
    """Candidate instances by name (all when ``names`` is None)."""
    from ..errors import IdentifyError

    chosen = list(CANDIDATES) if names is None else list(names)
    unknown = [n for n in chosen if n not in CANDIDATES]
    if unknown:
        raise IdentifyError(f"unknown effect(s) {', '.join(unknown)}; the library has {', '.join(CANDIDATES)}")
    return [CANDIDATES[n]() for n in chosen]
