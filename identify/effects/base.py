"""The shape every effect shares: where it acts, what it needs, its terms and its fitted parameters.

Equation (22) is the hysteresis; an *effect* is a physical mechanism beside
it.  Each effect acts at one stage of the model's pipeline -- the simulated
device's (:mod:`drivers.sim.effect_hooks`), seen from what a run records::

    heater voltage v --[input]--> hysterons' input x --memory curve--> signed areas s
      u = mu0 + c_d v + sum mu_ij s_ij(x) --[output]--> u + sum of contributions
        --[sensor]--> the reading y

* **input** effects change what the memory curve sees (``thermal_lag``,
  ``ambient_drift``, ``interaction``).  Their parameters enter through the
  hysteresis, so they are fitted by Gauss--Newton steps on secant
  *columns*: the change of the current model's output per unit of each
  parameter.  The thermal term follows the heater unless the effect says
  otherwise (:attr:`Effect.drives_thermal_term`).
* **output** effects add a contribution ``B beta`` (``reversible``,
  ``joule_power``, ``creep``, ``first_point``, ``baseline_drift``): columns
  ``B`` from what the run records, coefficients ``beta`` linear.
* **sensor** effects map the deflection to the reading (``sensor_nonlinearity``):
  ``y = u + phi(u) beta``, linear in ``beta`` at a given ``u``.

An effect may have a few nonlinear *settings* (a time constant, a sign) on
a small grid (:meth:`Effect.settings_grid`); its coefficients then enter
linearly.  The same columns serve the joint fit of a model with effects
(:mod:`identify.effects.joint`) and the gap diagnosis
(:mod:`identify.diagnosis`), which linearises around the base model.

An effect instance is either *unfitted* (``params is None``: it changes
nothing) or *fitted*: its ``params`` (JSON-safe, physical units) are what a
stored model keeps, and they alone determine how it acts on a run.
Per-run effects (drifts: :attr:`Effect.per_run`) describe only the runs
they were fitted on, by name; on another run they are unknown and
contribute nothing (a validation may re-estimate them, held out).
"""

from __future__ import annotations

from abc import ABC
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Protocol

import numpy as np

from ..errors import IdentifyError
from ..forward import Equation22
from ..grid import Grid
from ..memory import InitialState
from ..runs import Run

INPUT, OUTPUT, SENSOR = "input", "output", "sensor"
STAGES = (INPUT, OUTPUT, SENSOR)

#: How the inversion (:mod:`identify.inverse`) can take a fitted effect (:attr:`Effect.inversion`):
#: ``static`` a function of the set-point alone, a polynomial of degree :attr:`Effect.static_degree` between
#: :meth:`Effect.static_breakpoints_V`, read from :meth:`Effect.contribution`; ``offset`` a known offset at
#: each step for each direction of the move (affine in this step's output), read from
#: :meth:`Effect.contribution` on the history plus the candidate point; ``lag`` the set-point reaches the
#: hysterons through slow thermal modes (parameters ``drive``, ``time_constants_s``, ``fractions``), in
#: closed form at a step's dwell; ``feedback`` the hysterons feel ``v + k u`` (parameter ``k``);
#: ``sensor`` a monotone map of the deflection (:meth:`Effect.sense`), inverted first; ``inert`` it changes
#: nothing on the run being inverted.
INVERSIONS = ("static", "offset", "lag", "feedback", "sensor", "inert")


class HostModel(Equation22, Protocol):
    """What an effect reads of the model it acts beside: equation (22)'s parameters, the fitted effects it
    carries and its prediction.  A :class:`identify.model.PreisachModel` is one; the effects stand below
    the model (which acts with them on a run, :mod:`identify.effects.compose`) and know it by this shape."""

    @property
    def effects(self) -> tuple["Effect", ...]: ...

    def predict(self, inputs: np.ndarray, initial: InitialState = "negative",
                history: np.ndarray | None = None) -> np.ndarray:
        """Equation (22)'s output (um) for an input sequence (V), ``(n,)``, the effects left out."""

    def predict_many(self, inputs: np.ndarray) -> np.ndarray:
        """:meth:`predict` of each row of ``inputs`` ``(k, n)`` (V) from negative saturation, ``(k, n)``."""

    def without_effects(self) -> "HostModel":
        """This model's equation (22) part."""


class EffectNotIdentifiable(IdentifyError):
    """The runs cannot identify an effect's parameters (the reason says why and what would)."""


class EffectNotApplicable(IdentifyError):
    """A run lacks what an effect needs to act on it (time stamps, dwells, reversals, a heater voltage)."""


@dataclass(frozen=True, eq=False)
class Columns:
    """An effect's terms at one setting, linearised at a :class:`Context`.

    ``values[i]`` ``(n_i, k)``: the output change (um) per unit of each
    coefficient at every point of run ``i``; ``labels`` ``(k,)`` name the
    coefficients; ``nonneg`` ``(k,)`` marks coefficients that are >= 0 by
    their physics; ``run_of`` ``(k,)`` is the index of the run a per-run
    coefficient belongs to, ``-1`` for a structural one.  ``roughness``
    ``(k, k)`` (or None) is a penalty on the coefficients, applied with
    weight ``smoothing`` (relative to the data).
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


@dataclass(frozen=True, eq=False)
class Context:
    """Where effects are linearised, and what they may use of the runs and the current model.

    ``model`` is the current model's equation (22) part (its ``effects``
    are ignored here); per run ``i`` (identification runs first, then, in a
    diagnosis, the check runs), each ``(n_i,)``: ``inputs`` the hysterons'
    input at the current state (the heater voltage unless an input effect is
    on), ``thermal`` what the thermal term ``c_d`` multiplies, ``predictions``
    the model's output before the sensor stage (um), and ``feedback`` the
    output the hysterons are taken to feel (the measured output where
    measured, else the prediction).  ``output_centre``/``output_half_range``
    (um) describe the identification outputs.
    """

    grid: Grid
    model: "HostModel"
    runs: tuple[Run, ...]
    inputs: tuple[np.ndarray, ...]
    thermal: tuple[np.ndarray, ...]
    predictions: tuple[np.ndarray, ...]
    feedback: tuple[np.ndarray, ...]
    output_centre: float
    output_half_range: float
    #: ``x -> sum mu_ij s_ij(x) + mu0`` for ``model`` (the thermal term left out), ``(n,)`` -> ``(n,)``;
    #: None: :meth:`HostModel.predict`.  The joint fit passes a cached one.
    hysteresis: Callable[[np.ndarray], np.ndarray] | None = None
    #: Per run ``(n_i,)``: equation (22)'s part of the output (before the output effects); None: ``predictions``.
    bare: tuple[np.ndarray, ...] | None = None

    def bare_output(self, i: int) -> np.ndarray:
        """Run ``i``'s output before the output effects (what drives creep of the output), ``(n_i,)``."""
        return self.predictions[i] if self.bare is None else self.bare[i]

    @classmethod
    def of_model(cls, model: "HostModel", runs: tuple[Run, ...] | list[Run], n_fit: int | None = None) -> "Context":
        """The context of an equation (22) model without effects: the inputs are the heater voltages.

        ``n_fit`` (default: all) is how many leading runs are identification
        runs, whose measured outputs set the output scale.
        """
        runs = tuple(runs)
        preds = tuple(model.predict(r.inputs) for r in runs)
        fit = runs[: len(runs) if n_fit is None else n_fit] or runs
        measured = np.concatenate([r.measured for r in fit])
        lo, hi = float(np.min(measured)), float(np.max(measured))
        return cls(model.grid, model, runs, tuple(r.inputs for r in runs), tuple(r.inputs for r in runs), preds,
                   tuple(feedback_of(r, p) for r, p in zip(runs, preds)),
                   0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12))

    def response(self, i: int, x: np.ndarray, thermal: np.ndarray | None = None) -> np.ndarray:
        """The equation (22) part's output (um) on run ``i`` with hysterons' input ``x`` ``(n_i,)`` and
        the thermal term on ``thermal`` (default: as in this context)."""
        m = self.model
        th = self.thermal[i] if thermal is None else thermal
        x = np.asarray(x, dtype=float)
        part = self.hysteresis(x) if self.hysteresis is not None else m.predict(x) - m.c_d * x
        return part + m.c_d * np.asarray(th, dtype=float)

    def responses(self, i: int, xs: np.ndarray) -> np.ndarray:
        """:meth:`response` on run ``i`` for each row of ``xs`` ``(k, n_i)`` (the thermal term as in this
        context), ``(k, n_i)``: the same numbers, the model's replays batched when no cached
        ``hysteresis`` is given (:meth:`HostModel.predict_many`)."""
        m = self.model
        xs = np.asarray(xs, dtype=float)
        if self.hysteresis is None:
            part = m.predict_many(xs) - m.c_d * xs
        else:
            part = np.array([self.hysteresis(x) for x in xs]).reshape(xs.shape)
        return part + m.c_d * np.asarray(self.thermal[i], dtype=float)


def start_of(model: "HostModel", initial_V: float) -> tuple[float, float]:
    """Equation (22)'s output and its phase-transition part (um) at a run's initial state: the memory in
    negative saturation, the input risen to ``initial_V`` (V) and at rest there (the sequencer saturates
    at 0 V before the first point, and the first point's change is counted from there)."""
    u = float(model.without_effects().predict(np.array([float(initial_V)]))[0])
    return u, u - model.mu0 - model.c_d * float(initial_V)


def feedback_of(run: Run, prediction: np.ndarray) -> np.ndarray:
    """The output a run's hysterons are taken to feel: measured where measured, else ``prediction``."""
    return np.where(np.isfinite(run.outputs), run.outputs, prediction)


def felt(output: np.ndarray, source: str, mu0: float, c_d: float, thermal: np.ndarray) -> np.ndarray:
    """What the hysterons feel of an ``output`` (um): all of it (``source="output"``), or its phase part, the
    bias ``mu0`` (um) and thermal term ``c_d`` (um/V) times ``thermal`` (V) taken off (``"phase"``)."""
    return output if source == "output" else output - mu0 - c_d * np.asarray(thermal, dtype=float)


@dataclass(frozen=True)
class Loop:
    """A feedback of the output onto the hysterons' input (:meth:`Effect.loop`), as the prediction's
    fixed point ``x = a + k u`` (``x^2 = a^2 + k u`` when ``drive`` is ``"power"``) needs it: gain ``k``
    (V/um or V^2/um), what drives the input (``voltage`` or ``power``), what the hysterons feel of the output
    ``u`` (``output``: all of it; ``phase``: its phase-transition part, less ``reference_um``, the phase part
    where the mean field is zero)."""

    k: float
    drive: str = "voltage"
    source: str = "output"
    reference_um: float = 0.0

    def felt(self, output: np.ndarray, mu0: float, c_d: float, thermal: np.ndarray) -> np.ndarray:
        """What the hysterons feel of ``output`` (um), ``(n,)``: see :func:`felt`, less ``reference_um``."""
        return felt(output, self.source, mu0, c_d, thermal) - self.reference_um


class Effect(ABC):
    """One unmodelled effect (see the module doc); ``params`` None until fitted."""

    #: The effect's name (command lines, stored models, the diagnosis).
    name: ClassVar[str]
    #: One line for reports.
    summary: ClassVar[str]
    #: Mechanisms the library does not hold that this family also reaches, each in a few words: the verdict
    #: names them beside the effect, since the runs cannot tell them apart (only what is known of the rig can).
    look_alikes: ClassVar[tuple[str, ...]] = ()
    #: The stage it acts at: :data:`INPUT`, :data:`OUTPUT` or :data:`SENSOR`.
    stage: ClassVar[str]
    #: A nuisance that differs from run to run (a drift), fitted per run.
    per_run: ClassVar[bool] = False
    #: Its terms span the thermal term ``c_d v`` (and more): the model is fitted without it.
    replaces_thermal_term: ClassVar[bool] = False
    #: (input effects) the thermal term follows the effect's transformed input (the beam's temperature).
    drives_thermal_term: ClassVar[bool] = False
    #: Names of settings refined continuously (on a log scale) after the grid search, in the joint fit.
    continuous: ClassVar[tuple[str, ...]] = ()
    #: (input effects) Coefficients are where the parameters go, not steps: the joint fit adds the
    #: columns times :meth:`coefficients` to its target, so signs and penalties apply to the parameters.
    absolute: ClassVar[bool] = False
    #: Its terms scale with the model's own output (a gain): the joint fit linearises it at equation (22)
    #: fitted alone first, as it does input and sensor effects (from a zero model its columns would vanish).
    from_base: ClassVar[bool] = False
    #: The name of a more general effect this one is a special case of (None): when both explain a gap
    #: equally well, the diagnosis names the special case -- fewer terms, the same physics.
    within: ClassVar[str | None] = None
    #: Options it accepts after a colon on the command line (``reversible:monotone``): keyword arguments of
    #: its constructor, set True.
    options: ClassVar[tuple[str, ...]] = ()
    #: What a run must record for it to act on the run: checks ``runs -> why not`` (None: recorded), such as
    #: :func:`needs_time` (time stamps), :func:`needs_dwell` (dwells), :func:`needs_heater` (a heater
    #: voltage); :meth:`applicable` asks them in turn.
    must_record: ClassVar[tuple[Callable[[tuple[Run, ...]], str | None], ...]] = ()
    #: How the inversion takes it, one of :data:`INVERSIONS`; None: it cannot be inverted exactly
    #: (:meth:`inversion_refused` says why).
    inversion: ClassVar[str | None] = None
    #: (``static`` inversion) The degree of its polynomial of the set-point between breakpoints.
    static_degree: ClassVar[int] = 0

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        self.params = None if params is None else self.check_params(dict(params))

    @property
    def fitted(self) -> bool:
        return self.params is not None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"

    @property
    def spec(self) -> str:
        """How the command line names it: ``NAME`` or ``NAME:OPTION`` (the options set, :attr:`options`)."""
        return ":".join([self.name, *(o for o in self.options if getattr(self, o, False))])

    # ------------------------------------------------------------ what runs must record
    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        """Why this effect cannot act on these runs at all (None: it can): a run lacks what it needs
        (the first of :attr:`must_record` that says so)."""
        for missing in self.must_record:
            why = missing(runs)
            if why is not None:
                return why
        return None

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        """Why these runs cannot identify the effect's parameters (None: they can)."""
        return self.applicable(runs)

    # ------------------------------------------------------------ terms, linearised
    def settings_grid(self) -> list[dict[str, float]]:
        """The nonlinear settings to try (each a dict); ``[{}]`` when there are none."""
        return [{}]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """The effect's terms at ``setting``, linearised at ``ctx`` (see :class:`Columns`)."""
        raise NotImplementedError

    def nuisance_columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """(per-run effects) The terms that re-estimate this effect on a run it was not fitted on
        (:mod:`identify.effects.nuisance`); default :meth:`columns`."""
        return self.columns(ctx, setting)

    def with_fit(self, ctx: Context, setting: dict[str, float], coef: np.ndarray, cols: Columns) -> "Effect":
        """A fitted instance from the coefficients ``coef`` ``(k,)`` of ``cols`` (the columns of ``setting``
        at ``ctx``).  Input effects' coefficients are steps from this instance's parameters (zero when
        unfitted) unless they are :attr:`absolute`; the others' are the coefficients themselves."""
        raise NotImplementedError

    def coefficients(self, ctx: Context) -> np.ndarray:
        """(input effects, :attr:`absolute`) The current coefficients in the order of :meth:`columns` at ``ctx``."""
        raise NotImplementedError

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        """The fitted effect in physical terms for reports (default: its parameters); ``runs`` lets a
        per-run effect describe each run's nuisance over its measured points."""
        return dict(self.params or {})

    def fit_settings_grid(self) -> list[dict[str, float]]:
        """The settings the joint fit of a model tries (default: :meth:`settings_grid`); penalty weights
        that only the diagnosis's cross-validation can choose are left out."""
        return self.settings_grid()

    def scan(self, score: Callable[["Effect"], float]) -> "Effect | None":
        """(input effects) A fitted instance to start the joint fit from instead of no effect, found by
        ``score`` (the residual sum of squares, um^2, of the linear terms solved with a candidate held
        fixed); None (the default): start from no effect.  For effects too nonlinear for Gauss--Newton
        steps from zero (a lag as long as the dwells)."""
        return None

    def with_setting(self, setting: dict[str, float], ctx: Context | None = None) -> "Effect":
        """(input effects) This effect at ``setting`` with its coefficients kept (an unfitted one may start
        from a value the setting gives, scaled by ``ctx``): the point the joint fit linearises at when it
        tries the setting.  Other effects' settings only choose columns."""
        return self

    def bounds(self) -> dict[str, float]:
        """Largest plausible ``|coefficient|`` by label, where physics bounds it (the diagnosis's visibility test)."""
        return {}

    def for_another_run(self) -> "Effect":
        """(:attr:`per_run` effects) An unfitted effect for another run of the same rig, to be estimated on
        that run alone: what belongs to the rig, not the run, is kept (a gain drift's sensor zero).
        Default: a fresh one."""
        return type(self)()

    def knows_run(self, run_name: str) -> bool:
        """(:attr:`per_run` effects) Whether it was fitted on a run of this name (its parameters hold that
        run's realisation under ``"runs"``); other effects know every run."""
        return not self.per_run or run_name in (self.params or {}).get("runs", {})

    def loop(self) -> Loop | None:
        """(input effects whose transform feels the model's own output: mean-field feedback) The feedback
        the prediction solves for, point by point (:mod:`identify.effects.compose`); None when there is none
        (another kind of effect, not fitted, or a zero gain): the transform then needs no feedback."""
        return None

    # ------------------------------------------------------------ how it is inverted (fitted)
    def modes(self) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """(``lag`` inversion, fitted) Its slow thermal modes: time constants (s) ``(m,)``, the fraction of
        the rise each holds ``(m,)``, and what drives each (``"power"`` or ``"voltage"``)."""
        raise NotImplementedError(f"effect {self.name!r} has no thermal modes")

    def inverted_as(self) -> str | None:
        """How the inversion takes this fitted instance (default :attr:`inversion`); an instance whose
        parameters make it change nothing may say ``"inert"``."""
        return self.inversion

    def inversion_refused(self) -> str | None:
        """Why this fitted instance cannot be inverted exactly (None: it can, as :meth:`inverted_as` says)."""
        return None if self.inverted_as() is not None else "this inversion does not know how it acts"

    def static_breakpoints_V(self) -> list[float]:
        """(``static`` inversion) Where its polynomial of the set-point changes (V); none by default."""
        return []

    # ------------------------------------------------------------ acting on a run (fitted)
    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        """Validate stored parameters; raise :class:`IdentifyError` naming what is wrong."""
        return params

    def transform(self, run: Run, x: np.ndarray) -> np.ndarray:
        """(input) The hysterons' input ``(n,)`` given the input ``x`` ``(n,)`` before this effect."""
        return x

    #: (output) Whether the contribution depends on the model's own output (``contribution``'s ``u``).
    needs_output: bool = False

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        """(output) The effect's contribution to the output (um) at every point of ``run``, ``(n,)``;
        ``u`` ``(n,)`` is equation (22)'s output (um) and ``phase`` its phase-transition part (without the
        bias and the thermal term), where the effect depends on them; ``start`` the two at the run's
        initial state (:func:`start_of`), from which the first point's change is counted (None: no change
        into the first point)."""
        return np.zeros(run.n)

    def sense(self, u: np.ndarray) -> np.ndarray:
        """(sensor) The reading (um) for the deflection ``u`` (um), same shape."""
        return u

    def slope(self, u: np.ndarray) -> np.ndarray:
        """(sensor) ``d reading / d u`` at ``u``, same shape."""
        return np.ones_like(np.asarray(u, dtype=float))


# ---------------------------------------------------------------- shared helpers
def require_params(params: dict[str, Any], keys: tuple[str, ...], effect: str) -> None:
    missing = [k for k in keys if k not in params]
    if missing:
        raise IdentifyError(f"effect {effect!r} is missing the parameter(s) {', '.join(missing)}")


def finite(params: dict[str, Any], key: str, effect: str) -> float:
    try:
        value = float(params[key])
    except (TypeError, ValueError):
        raise IdentifyError(f"effect {effect!r}: parameter {key!r} is not a number") from None
    if not np.isfinite(value):
        raise IdentifyError(f"effect {effect!r}: parameter {key!r} is not finite")
    return value


def finite_array(params: dict[str, Any], key: str, effect: str) -> np.ndarray:
    try:
        value = np.asarray(params[key], dtype=float)
    except (TypeError, ValueError):
        raise IdentifyError(f"effect {effect!r}: parameter {key!r} is not a list of numbers") from None
    if value.ndim != 1 or not np.all(np.isfinite(value)):
        raise IdentifyError(f"effect {effect!r}: parameter {key!r} must be a list of finite numbers")
    return value


def needs_heater(runs: tuple[Run, ...]) -> str | None:
    """Not applicable unless the input is a heater voltage (V): the effect is heater physics."""
    units = {r.input_unit for r in runs}
    if units != {"V"}:
        return (f"it is heater physics (the input as a heater voltage), and these runs' input is in "
                f"{', '.join(sorted(units))}")
    return None


def needs_time(runs: tuple[Run, ...]) -> str | None:
    """Not applicable when a run's time stamps carry no information."""
    untimed = [r.name for r in runs if not r.timed]
    if untimed:
        return f"it acts over time, and {', '.join(untimed)} record(s) no time (all time stamps equal)"
    return None


def needs_dwell(runs: tuple[Run, ...]) -> str | None:
    """Not applicable when no run records its dwells (set-point to readings): what a lag acts over."""
    if not any(r.has_dwell for r in runs):
        return "no run records its dwell (set-point to readings), so there is nothing for a lag to act over"
    return None


def needs_reversals(runs: tuple[Run, ...], what: str) -> str | None:
    """Not identifiable when no run's input ever turns back."""
    if not any(r.history.reversal_index.size for r in runs):
        return f"{what}, and the input never turns back in {', '.join(r.name for r in runs)}"
    return None


def single_columns(runs: tuple[Run, ...], values: list[np.ndarray], labels: tuple[str, ...],
                   nonneg: tuple[bool, ...] | None = None) -> Columns:
    """Structural columns (shared by every run): ``values[i]`` ``(n_i, k)``."""
    k = len(labels)
    return Columns(tuple(np.asarray(v, dtype=float).reshape(r.n, k) for r, v in zip(runs, values)), labels,
                   nonneg if nonneg is not None else (False,) * k, (-1,) * k)
