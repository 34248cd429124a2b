"""Identifying recorded runs, one or many: plan every job, fit them (in parallel), store the models.

``rig identify`` goes through three steps, so that a batch is all or
nothing up to the storing:

1. :func:`plan_job` reads each file and checks everything that can be
   checked without fitting: the file is a usable run (partial sessions
   only with ``--partial``), the grid, ``--measurements``, and where the
   model will be stored (a free name, unless ``--force``);
2. :func:`fit_job` fits one planned job -- a pure function of the job, run
   in a worker process when there are several (:mod:`rig.parallel`), so a
   batch gives exactly the results of one file at a time;
3. :func:`store_model` writes the model into its session
   (:func:`sessions.add_model`: a checked copy renamed over the original).

Settings from the session (``rig acquire`` records how a session wants to
be identified, :class:`sessions.IdentifyRecipe`): the settings a caller
leaves to it (:attr:`IdentifyOptions.from_recipe`; ``rig identify`` leaves
every one it is not given) come from the session's recipe when it has one
(:func:`apply_recipe`), and the job says where each came from.

Storing policy (``--store``, the default, for sessions; a CSV trace is
never modified): the model goes to ``/models/NAME``, NAME being ``--name``
or :func:`default_model_name`.  A partial session is fitted only with
``--partial``, and then stored only when ``--name`` asks for it and the
session is finished (aborted or failed: a running session's file belongs to
its writer).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from identify import Grid, IdentifyError
from identify.effects import Effect, parse_effects
from identify.fit import FitReport, fit_run, measurement_rows
from identify.runs import Run
from identify.model_json import model_to_dict
from sessions import IdentifyRecipe, ModelRecord, add_model
from sessions.models import check_model_name
from sessions.recording import Recording

from .curve_selection import selected_rows
from .errors import UserError
from .session_input import open_run, partial_state, run_of, same_file


def report_dict(report: FitReport, thermal_term: bool, seed: int | None) -> dict:
    """The ``rig identify --json`` object; also a model file ``rig predict`` reads.

    With effects the model's ``effects`` (``[{"name", "params"}]``) are in it,
    and ``effect_settings`` the nonlinear settings the fit chose."""
    extra = {}
    if report.model.effects:
        extra = {"effect_settings": report.info.get("effect_settings")}
    if report.info.get("simulated_rmse") is not None:
        extra["simulated_rmse_um"] = report.info["simulated_rmse"]
    return {
        "method": report.method,
        **model_to_dict(report.model),
        "thermal_term": thermal_term,
        "rmse_um": report.rmse,
        "nrmse": report.nrmse,
        "max_abs_um": report.max_abs,
        "n_measured": report.n_measured,
        "n_points": report.n_points,
        "seed": seed,
        "seconds": report.seconds,
        "settings": report.settings,
        **extra,
    }


def default_range(data: Recording) -> tuple[float, float]:
    """The grid range without --v-min/--v-max: the recorded grid's, else the measured inputs'.

    The measured inputs of the whole run, whatever ``--curves`` selects, so
    that models fitted on different selections share a grid and each can
    predict the others.  Applied points beyond it (a FORC protocol's
    saturation field) saturate the model, as they saturate the sample.
    """
    if data.grid is not None:
        return data.grid.v_min, data.grid.v_max
    measured = data.inputs[data.measured_rows]
    return float(np.min(measured)), float(np.max(measured))


def grid_for(levels: int | None, v_min: float | None, v_max: float | None, data: Recording) -> Grid:
    """The grid: the options, else the one the session records, else the measured inputs' min and max."""
    recorded = data.grid
    if levels is None:
        if recorded is None:
            if data.session is None:
                raise UserError("--levels is required to identify from a CSV trace")
            raise UserError(f"--levels is required: {data.path} records no grid")
        levels = recorded.levels
    lo, hi = default_range(data)
    return Grid(levels, lo if v_min is None else v_min, hi if v_max is None else v_max)


def default_model_name(
    method: str,
    grid: Grid,
    *,
    levels: int | None,
    v_range: tuple[float, float],
    measurements: int | None = None,
    seed: int | None = None,
    thermal_term: bool = True,
    curves: str = "all",
    effects: tuple[Effect, ...] = (),
) -> str:
    """The name a model is stored under when ``--name`` is not given.

    ``levels`` and ``v_range`` are the defaults the run offers: its recorded
    grid's levels (``None`` when it records none) and range (else the
    data's).  The name is the method, then what was chosen differently from
    those defaults, so that two fits get the same name exactly when they
    were asked for the same way: ``-L<levels>`` when the levels are not the
    run's own, ``-r<v_min>_<v_max>`` when the range is not the default one,
    ``-M<M>-s<seed>`` for a random choice of rows, ``-nothermal``
    without the thermal term and ``-even``/``-odd`` for a selection of
    curves, and ``+<effect>`` for every effect fitted with it (``--with``; an
    option after a dot).  E.g. ``ls``, ``cs_order_nn-M300-s0``,
    ``ls-L20-nothermal``, ``smooth_nn-L40-even``, ``ls+reversible``,
    ``ls-even+reversible.monotone+interaction``.
    """
    parts = [method]
    if levels is None or grid.levels != levels:
        parts.append(f"L{grid.levels}")
    if (grid.v_min, grid.v_max) != tuple(v_range):
        parts.append(f"r{grid.v_min:g}_{grid.v_max:g}")
    if measurements is not None:
        parts.append(f"M{measurements}-s{seed}")
    if not thermal_term:
        parts.append("nothermal")
    if curves != "all":
        parts.append(curves)
    return "-".join(parts) + "".join(f"+{e.spec.replace(':', '.')}" for e in effects)


@dataclass(frozen=True)
class IdentifyOptions:
    """The ``rig identify`` options that apply to every file."""

    levels: int | None = None
    v_min: float | None = None
    v_max: float | None = None
    method: str = "ls"
    measurements: int | None = None
    seed: int = 0
    thermal_term: bool = True
    store: bool = True
    name: str | None = None
    force: bool = False
    partial: bool = False
    #: The methods' ``solver`` setting ("fast" or "dense"), or None for their default.
    solver: str | None = None
    curves: str = "all"
    #: Effects fitted jointly with the density (``--with``), unfitted, parsed once where they are given
    #: (:func:`identify.effects.parse_effects`); a session's recipe's are parsed by :func:`apply_recipe`.
    effects: tuple[Effect, ...] = ()
    #: The settings (names among :data:`RECIPE_SETTINGS`) left to a session's identification recipe: for a
    #: session that records one they come from it; the values above are what any other file gets.  Empty
    #: (the default): the options are used as they are.  ``rig identify`` leaves every setting it is not given.
    from_recipe: frozenset[str] = frozenset()


#: The settings an identification recipe holds, by their :class:`IdentifyOptions` names.
RECIPE_SETTINGS = ("method", "levels", "v_min", "v_max", "thermal_term", "effects")


def apply_recipe(o: IdentifyOptions, recipe: IdentifyRecipe | None, path: Path) -> tuple[IdentifyOptions, dict]:
    """The options for one file: ``o`` with the settings it leaves to the recipe taken from ``recipe`` (the
    session's, None: it has none), and where each setting came from: ``{"method": "session", ...}`` --
    ``option`` (given), ``session`` (the recipe) or ``default`` (left to the recipe, which does not set it:
    what ``rig identify`` does for a file without one)."""
    sources = {}
    changes = {}
    for key in RECIPE_SETTINGS:
        if key not in o.from_recipe:
            sources[key] = "option"
            continue
        value = None if recipe is None else getattr(recipe, key)
        if value is None:
            sources[key] = "default"
            continue
        sources[key] = "session"
        changes[key] = value
    if changes.get("method") is not None:
        from identify.methods import METHODS

        if changes["method"] not in METHODS:
            raise UserError(f"{path}: its identification recipe names the method {changes['method']!r}, which this "
                            f"version does not know; give --method ({', '.join(METHODS)})")
    if changes.get("effects"):
        try:
            changes["effects"] = tuple(parse_effects(changes["effects"]))
        except IdentifyError as exc:
            raise UserError(f"{path}: its identification recipe's effects: {exc}; give --with") from None
    return dataclasses.replace(o, **changes), sources


@dataclass(frozen=True, eq=False)
class IdentifyJob:
    """One file to fit, fully checked: the data, the rows to fit and where the model goes.

    ``run`` is the recorded run the fit reads: every applied point (its
    ``inputs`` and ``outputs`` ``(n,)``, outputs NaN where not measured),
    time stamps and dwells; ``rows`` the measured rows the fit uses; ``seed``
    the seed of their random choice (``None`` when all are used);
    ``store_as`` the model name in the session, or ``None`` when the model
    is not stored; ``partial`` describes a partial session (else ``None``);
    ``label`` prefixes fitting errors (set in batches, to name the file);
    ``curves`` ``(n,)`` the curve of every point (-1: none), when the run has curves;
    ``effects`` the (unfitted) effects to fit with the density, none for equation
    (22) alone.
    """

    path: Path
    grid: Grid
    run: Run
    rows: np.ndarray
    method: str
    thermal_term: bool
    seed: int | None
    input_unit: str
    output_unit: str
    store_as: str | None = None
    partial: str | None = None
    label: str | None = None
    solver: str | None = None
    curves: np.ndarray | None = None
    curve_selection: str = "all"
    effects: tuple[Effect, ...] = ()
    #: The grid the session records (None: none), which :func:`check_grid` compares ``grid`` with.
    recorded_grid: Grid | None = None
    #: The identification recipe the session records (None: none) and where each setting of this job came
    #: from (:func:`apply_recipe`).
    recipe: IdentifyRecipe | None = None
    sources: dict[str, str] | None = None

    @property
    def inputs(self) -> np.ndarray:
        """Every applied input ``(n,)`` (the run's)."""
        return self.run.inputs

    @property
    def outputs(self) -> np.ndarray:
        """Every output ``(n,)``, NaN where not measured (the run's)."""
        return self.run.outputs


def _store_as(data: Recording, o: IdentifyOptions, grid: Grid) -> str | None:
    s = data.session
    if s is None or not o.store:
        return None
    if s.is_partial:
        if o.name is None:
            return None
        if not s.status.final:
            raise UserError(
                f"{data.path}: a model is stored only in a finished session, and this one is "
                f"{s.status.value}; fit it without --name, or finish or resume the run first"
            )
    name = o.name
    if name is None:
        name = default_model_name(
            o.method, grid, levels=None if s.grid is None else s.grid.levels, v_range=default_range(data),
            measurements=o.measurements, seed=o.seed, thermal_term=o.thermal_term, curves=o.curves,
            effects=o.effects,
        )
    check_model_name(name)
    if name in s.models and not o.force:
        hint = "" if o.name is not None else " or --name to store it under another name"
        raise UserError(f"{data.path}: already holds a model named {name!r}; use --force to replace it{hint}")
    return name


def plan_job(path: str | Path, o: IdentifyOptions, label: str | None = None) -> IdentifyJob:
    """Read ``path`` and check everything about fitting it and storing the result."""
    path = Path(path)
    data = open_run(path, allow_partial=o.partial)
    recipe = None if data.session is None else data.session.recipe
    o, sources = apply_recipe(o, recipe, path)
    if o.name is not None and data.session is None:
        raise UserError(f"--name stores the model in a session, but {path} is a CSV trace (rig import it first)")
    grid = grid_for(o.levels, o.v_min, o.v_max, data)
    candidates = selected_rows(data, o.curves)
    if o.measurements is not None and not 1 <= o.measurements <= candidates.size:
        what = f"N={candidates.size}" if data.session is None else f"the {candidates.size} measured points"
        if o.curves != "all":
            what += f" on the {o.curves} curves"
        raise UserError(f"--measurements {o.measurements} must be between 1 and {what}")
    rows = measurement_rows(grid, data.inputs, o.measurements, o.seed, o.thermal_term, candidates)
    run = _checked_run(path, data, grid, rows, o, sources["effects"])
    s = data.session
    return IdentifyJob(
        path=path,
        grid=grid,
        run=run,
        rows=rows,
        method=o.method,
        thermal_term=o.thermal_term,
        seed=o.seed if o.measurements is not None else None,
        input_unit=data.input_unit,
        output_unit=data.output_unit,
        store_as=_store_as(data, o, grid),
        partial=partial_state(s) if s is not None and s.is_partial else None,
        label=label,
        solver=o.solver,
        curves=data.curves,
        curve_selection=o.curves,
        effects=o.effects,
        recorded_grid=data.grid,
        recipe=recipe,
        sources=sources,
    )


#: A fit with more than this many cells per measured point is refused unless --yes: the data cannot
#: identify them (compressive fits of the paper use up to about 10).
CELLS_PER_POINT = 20


def check_grid(job: IdentifyJob, yes: bool) -> None:
    """Name the real cause when the grid does not fit the data: far more cells than measured points (refused
    unless ``yes``), or a grid other than the session's own on whose walls every measured input sits."""
    grid, recorded = job.grid, job.recorded_grid
    measured = job.inputs[job.rows[job.rows < job.inputs.size]]
    n = int(measured.size)
    mismatch = ""
    if recorded is not None and (grid.levels, grid.v_min, grid.v_max) != (recorded.levels, recorded.v_min,
                                                                       recorded.v_max):
        mismatch = (f"the grid does not match the session's inputs, which were planned on its own grid (L = "
                    f"{recorded.levels} on [{recorded.v_min:g}, {recorded.v_max:g}] {job.input_unit})")
    if grid.n_cells > CELLS_PER_POINT * n and not yes:
        most = int((math.isqrt(8 * n + 1) - 1) // 2)
        use = f"-L {recorded.levels} (or no -L)" if mismatch else f"at most -L {most}"
        raise UserError(f"{job.path}: L = {grid.levels} has {grid.n_cells:,} cells but the {n} measured points can "
                        f"identify at most {n} (a grid of L = {most}){'; ' + mismatch if mismatch else ''}; nothing "
                        f"was fitted -- use {use}, or add --yes to fit it anyway")
    if mismatch and job.thermal_term and n and np.all(grid.on_walls(measured)):
        raise UserError(f"{job.path}: every measured input sits on a wall of the L = {grid.levels} grid, where the "
                        f"thermal term cannot be identified, because {mismatch}; use -L {recorded.levels} (or no -L)")


def _checked_run(path: Path, data: Recording, grid: Grid, rows: np.ndarray, o: IdentifyOptions,
                 source: str = "option") -> Run:
    """The run to fit (every measured output: the fit takes ``rows``), checked before anything is fitted
    when effects are asked for: a method that can fit them, and a run whose ``rows`` can identify them
    (one-line errors otherwise; ``source``: where the effects came from, ``session`` naming the session's
    recipe)."""
    from identify.methods import METHODS

    run = run_of(data)
    if not o.effects:
        return run
    given = "--with" if source != "session" else f"{path}: the effects of its identification recipe"
    if METHODS[o.method].needs_curves:
        raise UserError(f"{given}: {o.method} takes the density from the curves' second differences and fits "
                        "no other terms; fit effects with ls or smooth_nn")
    if METHODS[o.method].needs_square:
        raise UserError(f"{given}: {o.method} needs the square damped-oscillation design, which has no room for "
                        "effect terms; fit effects with ls or smooth_nn (or everett on FORC data)")
    fitted = run.keeping(rows)
    for e in o.effects:
        why = e.identifiable((fitted,), grid)
        if why is not None:
            raise UserError(f"{path}: {e.name} cannot be identified from this run: {why}")
    return run


def fit_job(job: IdentifyJob, progress: Callable[[str], None] | None = None, mapper=None) -> FitReport:
    """Fit one planned job (runs in a worker process in batches); the model carries the run's units.
    ``progress``: see :func:`identify.fit.fit_sequence` (the fit of a model without effects reports stages);
    ``mapper``: how the effects' grid search runs its jobs (:func:`identify.fit.fit_run`)."""
    settings = None if job.solver is None else {"solver": job.solver}
    try:
        report = fit_run(job.grid, job.run, job.method, job.effects, rows=job.rows, thermal_term=job.thermal_term,
                         settings=settings, curves=job.curves, progress=progress, mapper=mapper)
    except IdentifyError as exc:
        if job.label is None:
            raise
        raise type(exc)(f"{job.label}: {exc}") from None
    metadata = dict(report.model.metadata)
    if job.curve_selection != "all":
        metadata["curves"] = job.curve_selection
    model = dataclasses.replace(report.model, input_unit=job.input_unit, output_unit=job.output_unit,
                                metadata=metadata)
    return dataclasses.replace(report, model=model)


def thermal_term_used(job: IdentifyJob) -> bool:
    """Whether the fit had the thermal term: asked for, and not replaced by an effect (``reversible``)."""
    return job.thermal_term and not any(e.replaces_thermal_term for e in job.effects)


def store_model(job: IdentifyJob, report: FitReport, force: bool) -> ModelRecord:
    """Store the fitted model in the job's session under ``job.store_as``; returns the record stored."""
    if job.store_as is None:
        raise ValueError("this job's model is not to be stored")
    record = ModelRecord.from_report(job.store_as, report, thermal_term_used(job), job.seed)
    add_model(job.path, record, force=force)
    return record


def recipe_dict(job: IdentifyJob) -> dict:
    """The settings the fit used and where each came from (``from``: ``option``, ``session`` or ``default``),
    with the session's recipe as stored (``stored``)."""
    g = job.grid
    return {"method": job.method, "levels": g.levels, "v_min": g.v_min, "v_max": g.v_max,
            "thermal_term": job.thermal_term, "effects": [e.spec for e in job.effects], "from": dict(job.sources or {}),
            "stored": None if job.recipe is None else job.recipe.to_dict()}


def result_dict(job: IdentifyJob, report: FitReport) -> dict:
    """The JSON object of one file: :func:`report_dict`, plus ``name`` when the model is stored and
    ``recipe`` (:func:`recipe_dict`) when the session records an identification recipe."""
    result = report_dict(report, thermal_term_used(job), job.seed)
    result["curves"] = job.curve_selection
    if job.store_as is not None:
        result["name"] = job.store_as
    if job.recipe is not None:
        result["recipe"] = recipe_dict(job)
    return result


def plan_jobs(paths: list[Path], o: IdentifyOptions) -> list[IdentifyJob]:
    """Plan every file (see :func:`plan_job`); the same file twice is refused."""
    for k, p in enumerate(paths):
        for q in paths[:k]:
            if Path(p).exists() and Path(q).exists() and same_file(p, q):
                raise UserError(f"{p}: given twice (as {q})")
    batch = len(paths) > 1
    return [plan_job(p, o, label=str(p) if batch else None) for p in paths]
