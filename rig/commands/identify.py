"""``rig identify``: fit a Preisach model to recorded runs, and store it in each session."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path

import click
from click.core import ParameterSource

from identify import METHODS
from identify.methods.base import SOLVERS
from identify.effects import parse_effects
from identify.effects import spellings as effect_spellings
from identify.threads import single_threaded, user_chose_threads

from ..budget.identification import PROGRESS_AFTER_S, job_cost
from ..budget.limits import refuse_unless_confirmed
from ..curve_selection import CURVE_CHOICES
from ..errors import UserError
from ..fit_progress import fit_in_process
from ..options import AliasedOption, scheduler_option
from ..output import format_table, print_json, unit_token
from ..parallel import cluster_workers, default_workers, helper_mapper, run_parallel, start_workers
from ..reidentify import (RECIPE_SETTINGS, IdentifyOptions, check_grid, fit_job, plan_jobs, result_dict,
                          store_model)


#: What the worker processes import before they fork (fit_job and everything it needs).
WORKER_MODULES = ["rig.reidentify"]


#: Work (measured rows x parameters, summed over the files) below which a batch is fitted in this
#: process unless --jobs asks otherwise: about 2 s of fitting on one core, what starting a pool of
#: workers (a fork server importing numpy, scipy and cvxpy) costs; at L = 30, M = 300 a fit is
#: 140k and 10-50 ms, at L = 100, M = 3,284 it is 17M and 0.6-2.4 s (docs/results, speed and scale).
PARALLEL_WORK = 20_000_000


#: Work -- measured rows times the settings of the effects' grid searches -- from which a fit in this
#: process shares its grid search with a helper process when a second core is free (the helper's start
#: costs the other core about a second of imports; this process does not wait for it).  The simulated
#: bench's L = 30 run with ``--with interaction``, 467 x 20, fits in about 3 s alone; the shared FORC
#: file's even curves with it, 41,907 x 20, in about 36 s alone.
SEARCH_HELPER_WORK = 20_000


def search_mapper(planned):
    """How the fits of a batch in this process run their effects' grid searches: shared with a helper
    process (:func:`rig.parallel.helper_mapper`) when one of them is work enough
    (:data:`SEARCH_HELPER_WORK`), both processes compute alike (one BLAS thread, as the joint fit of a
    small grid has: :mod:`identify.threads`, or the threads the user set for both) and a core is free;
    else None."""
    def work(job) -> int:
        return int(job.rows.size) * sum(len(g) for g in (e.fit_settings_grid() for e in job.effects) if len(g) > 1)

    if not any(work(job) >= SEARCH_HELPER_WORK and (single_threaded(job.grid.n_cells + 2) or user_chose_threads())
               for job in planned):
        return None
    return helper_mapper(WORKER_MODULES)


def batch_work(planned) -> int:
    """Measured rows times parameters, summed over the planned fits: what their time grows with."""
    return sum(int(job.rows.size) * (job.grid.n_cells + 2) for job in planned)


def save_targets(save: Path | None, paths: list[Path]) -> list[Path | None]:
    """Where ``--out`` writes each model: the file itself for one run, ``DIR/<stem>.json`` for several."""
    if save is None:
        return [None] * len(paths)
    if len(paths) == 1:
        if save.is_dir():
            raise UserError(f"--out {save}: is a directory; give the JSON file to write")
        return [save]
    if save.exists() and not save.is_dir():
        raise UserError(f"--out {save}: with several files --out names a directory (one <name>.json per file)")
    targets = [save / f"{p.stem}.json" for p in paths]
    seen: dict[Path, Path] = {}
    for p, t in zip(paths, targets):
        if t in seen:
            raise UserError(f"--out: {seen[t]} and {p} would both be saved as {t}")
        seen[t] = p
    return targets


#: A model fitted with its output fed back (``interaction``) whose own prediction of the run is this many times
#: worse than the model without effects is said to be so.
FED_BACK_WORSE = 1.0


@click.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--levels", "-L", type=int,
              help="Discretisation levels L (>= 1); default for a session: its recipe's, else its excitation's.")
@click.option("--v-min", type=float,
              help="Lower end of the grid (input unit); default: the session's recipe's or grid, else the smallest "
                   "measured input.")
@click.option("--v-max", type=float,
              help="Upper end of the grid (input unit); default: the session's recipe's or grid, else the largest "
                   "measured input.")
@click.option(
    "--method", type=click.Choice(list(METHODS)), default="ls",
    help="Identification method [ls; a session that records a recipe: its method].",
)
@click.option(
    "--solver", type=click.Choice(list(SOLVERS)), default=None,
    help="fast (the default): matrix-free operators and structured solvers; "
    "dense: the dense reference formulation (small problems only).",
)
@click.option("--measurements", "-M", type=int,
              help="Use only M of the measured rows, chosen at random (default: all).")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed for choosing the M rows.")
@click.option("--curves", type=click.Choice(CURVE_CHOICES), default="all", show_default=True,
              help="Fit the measured points of these curves only (numbered from 0; runs made of curves, "
                   "e.g. an imported FORC file); every applied point still sets the memory state.")
@click.option(
    "--thermal-term/--no-thermal-term", default=True, show_default=True,
    help="Fit the linear thermal term c_d v of equation (22) [a session that records a recipe: as it says].",
)
@click.option("--with", "with_effects", multiple=True, metavar="EFFECT[,EFFECT...]",
              help="Fit these unmodelled effects jointly with the density and keep them in the model "
                   f"(ls, smooth_nn): {effect_spellings()} [none; a session that records a recipe: its effects].")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--out", "-o", "save", cls=AliasedOption, aliases=("--save",), type=click.Path(path_type=Path),
              metavar="PATH",
              help="Also write the model as JSON here (several files: into this directory, <stem>.json each).")
@click.option("--name", help="Store the model under /models/NAME (default: the method and the options given).")
@click.option("--store/--no-store", default=True, show_default=True,
              help="Store the model in each session (a CSV trace is never modified).")
@click.option("--force", is_flag=True, help="Replace a stored model of the same name.")
@click.option("--partial", is_flag=True,
              help="Fit partial sessions (running, aborted, failed) too; such a model is stored only with --name.")
@click.option("--jobs", "-j", type=click.IntRange(min=1),
              help="Processes for several files (default: one per core, at most one per file; one when the fits are too small to repay starting workers).")
@scheduler_option
@click.option("--yes", is_flag=True,
              help="Fit even when the estimate is over the documented limits (30 min or 4 GB per file), or the grid "
                   "has far more cells (over 20 per point) than the measured points can identify.")
@click.pass_context
def identify(ctx, files, levels, v_min, v_max, method, solver, measurements, seed, curves, thermal_term, with_effects,
             as_json, save, name, store, force, partial, jobs, scheduler, yes):
    """Identify a Preisach model from each FILE: a session (HDF5) or a CSV trace (t_s,v_V,deflection_um).

    From a session, the fit uses the measured points; every applied point
    (measured or not) sets the memory state of the points after it. The
    model is stored in the session under /models/NAME; an existing model
    is never replaced without --force. Several files are fitted in
    parallel; every file is checked before any is fitted, and nothing is
    stored unless every fit succeeds.

    A session that records how it wants to be identified (rig acquire
    writes it) is fitted that way -- method, grid, thermal term, effects --
    except for the options given, which always win.
    """
    if name is not None and not store:
        raise UserError("--name stores the model; it cannot go with --no-store")
    if jobs is not None and scheduler is not None:
        raise UserError("--jobs sets the local processes; with --scheduler the cluster's workers fit the files")
    paths = list(files)
    names = [e.strip() for spec in with_effects for e in spec.split(",")]
    if "" in names:
        given = ", ".join(f"--with {spec!r}" for spec in with_effects)
        raise UserError(f"{given}: names an empty effect; give EFFECT[,EFFECT...] (or leave --with out for none)")
    # parsed once, here: unknown names, options or repeats are one line before any file is read
    effects = tuple(parse_effects(names))
    params = {"method": "method", "levels": "levels", "v_min": "v_min", "v_max": "v_max",
              "thermal_term": "thermal_term", "effects": "with_effects"}
    from_recipe = frozenset(key for key in RECIPE_SETTINGS
                            if ctx.get_parameter_source(params[key]) in (ParameterSource.DEFAULT, None))
    options = IdentifyOptions(levels, v_min, v_max, method, measurements, seed, thermal_term, store, name, force,
                              partial, solver=solver, curves=curves, effects=effects, from_recipe=from_recipe)
    targets = save_targets(save, paths)
    start = time.perf_counter()
    if scheduler is not None:
        workers = cluster_workers(scheduler)  # and a scheduler that does not answer is said before any file is read
    else:
        workers = default_workers(len(paths), jobs)
    if workers > 1 and jobs is not None:
        start_workers(WORKER_MODULES)  # their imports overlap the reading and checking below
    planned = plan_jobs(paths, options)
    if scheduler is None and jobs is None and workers > 1 and batch_work(planned) < PARALLEL_WORK:
        workers = 1  # a pool costs about a second to start: more than these fits take one after another
    costs = [job_cost(job) for job in planned]  # stated before a long fit, refused above the limits
    for job, cost in zip(planned, costs):
        refuse_unless_confirmed(f"rig identify {job.path}", cost.exceeded(), yes)
    for job in planned:
        check_grid(job, yes)  # after the estimate: a fit too big to run is refused as such first
    for job, cost in zip(planned, costs):
        if job.partial is not None:
            click.echo(f"warning: {job.path} is partial ({job.partial})", err=True)
        if cost.seconds > PROGRESS_AFTER_S:
            click.echo(f"{job.path}: {cost.describe()}", err=True)
    if workers == 1 and scheduler is None:
        mapper = search_mapper(planned)
        fit = fit_job if mapper is None else functools.partial(fit_job, mapper=mapper)
        reports = fit_in_process(fit, planned, costs, [f"rig identify: {job.path}" for job in planned])
    else:
        reports = run_parallel(fit_job, planned, workers, desc="identify", unit="file", preload=WORKER_MODULES,
                               scheduler=scheduler)
    for job, report in zip(planned, reports):
        if job.store_as is not None:
            store_model(job, report, force)
    results = [result_dict(job, report) for job, report in zip(planned, reports)]
    for target, result in zip(targets, results):
        if target is not None:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    seconds = time.perf_counter() - start
    if as_json:
        if len(results) == 1:
            print_json(results[0])
        else:
            print_json({"results": [{"file": str(p), **r} for p, r in zip(paths, results)],
                        "workers": workers, "seconds": seconds})
        return
    if len(planned) == 1:
        _print_one(planned[0], reports[0])
    else:
        _print_batch(planned, reports, workers, seconds, scheduler)


def describe_sources(job) -> str:
    """Where the settings of a job came from, in one line (for a session that records a recipe)."""
    g, src = job.grid, job.sources or {}
    items = [("method", f"method {job.method}"), ("levels", f"L={g.levels}"),
             ("v_min", f"v_min {g.v_min:g}"), ("v_max", f"v_max {g.v_max:g}"),
             ("thermal_term", "thermal term" if job.thermal_term else "no thermal term"),
             ("effects", f"with {','.join(e.spec for e in job.effects)}" if job.effects else "no effects")]
    words = {"session": "the session's recipe", "option": "given", "default": "default"}
    groups: dict[str, list[str]] = {k: [] for k in words}  # in this order: the session's, given, default
    for key, text in items:
        groups[src.get(key, "option")].append(text)
    return "; ".join(f"from {words[k]}: {', '.join(v)}" if k == "session" else f"{words[k]}: {', '.join(v)}"
                     for k, v in groups.items() if v)


def _print_one(job, report) -> None:
    g, m, u = job.grid, report.model, unit_token(job.output_unit)
    click.echo(f"{job.path}: {report.method} on L={g.levels} levels, [{g.v_min:g}, {g.v_max:g}] {job.input_unit}")
    if job.recipe is not None:
        click.echo(f"settings {describe_sources(job)}")
    click.echo(
        format_table(
            ["measured", "of", f"rmse_{u}", "nrmse", f"max_abs_{u}", f"mu0_{u}",
             f"c_d_{u}_per_{unit_token(job.input_unit)}", "seconds"],
            [[report.n_measured, report.n_points, report.rmse, report.nrmse, report.max_abs,
              m.mu0, m.c_d, report.seconds]],
        )
    )
    simulated, base = report.info.get("simulated_rmse"), report.info.get("base_rmse")
    if simulated is not None:
        click.echo(f"on its own (the output not fed back as measured) the model predicts this run to "
                   f"{simulated:.4g} {u} rms")
        if base is not None and simulated > FED_BACK_WORSE * base:
            click.echo(f"warning: that is worse than the model without effects ({base:.4g} {u}): the fit leaned on "
                       f"the measured output fed back, and the model will mispredict other runs", err=True)
    if job.store_as is not None:
        click.echo(f"stored as /models/{job.store_as} in {job.path}")


def _print_batch(planned, reports, workers, seconds, scheduler=None) -> None:
    units = {j.output_unit for j in planned}
    same = len(units) == 1
    rmse_col = f"rmse_{unit_token(units.pop())}" if same else "rmse"
    headers = ["file", "method", "L", "measured", "of", rmse_col, "nrmse", "seconds", "stored as"]
    if not same:
        headers.insert(6, "unit")
    rows = []
    for job, r in zip(planned, reports):
        row = [str(job.path), r.method, job.grid.levels, r.n_measured, r.n_points, r.rmse, r.nrmse, r.seconds,
               "-" if job.store_as is None else f"/models/{job.store_as}"]
        if not same:
            row.insert(6, job.output_unit)
        rows.append(row)
    click.echo(format_table(headers, rows))
    recipes = [job for job in planned if job.recipe is not None and "session" in (job.sources or {}).values()]
    if recipes:
        click.echo(f"{len(recipes)} of {len(planned)} files fitted (in part) as their session's recipe says "
                   "(--json: recipe.from says where each setting came from)")
    where = f"{workers} process{'es' if workers > 1 else ''}"
    if scheduler is not None:
        where = f"the cluster at {scheduler} ({workers} worker thread{'s' if workers > 1 else ''})"
    click.echo(f"{len(planned)} files in {seconds:.3g} s on {where}")
