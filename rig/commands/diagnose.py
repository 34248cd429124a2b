"""``rig diagnose``: where equation (22) misses on held-out runs, which unmodelled effect causes it,
and how far the gap shrinks once that effect is added."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from identify.diagnosis import NAMES, DiagnosisSettings, diagnose as run_diagnosis, library
from identify.methods import METHODS
from identify.threads import single_threaded, user_chose_threads

from ..curve_selection import CURVE_CHOICES
from ..diagnosis.calibration import drift_agreement
from ..diagnosis.discriminate import (DEFAULT_POINTS, MAX_POINTS, MIN_POINTS, changed, checked_request, checked_session,
                                      discriminate as plan_run, readings_for, to_line, verdict_summary)
from ..diagnosis.loading import load_runs
from ..diagnosis.report import to_json, to_text, write_figures
from ..errors import UserError
from ..options import AliasedOption
from ..output import print_json
from ..parallel import helper_mapper

_PATH = click.Path(dir_okay=False, path_type=Path)
#: What the helper process that scores half the candidates imports once (its fork server, started early).
HELPER_MODULES = ("identify.diagnosis.engine", "rig.parallel")
#: Least work -- measured check points times the settings of the candidates asked for, summed -- for which
#: the candidates are shared with a helper process: below, they are done before the helper has started
#: (its imports take about a second of the other core).  L = 30 with 360 check points and the whole
#: library: 360 x 83; L = 8 with 100: 100 x 83 (the diagnosis takes 1.2 s in all).
HELPER_MIN_WORK = 15_000


def _candidate_mapper(loaded, effects: tuple[str, ...] | None):
    """How the diagnosis runs its candidates: shared between this process and a helper process
    (:func:`rig.parallel.map_with_helper`) when a second core is free -- two or more cores, and fewer
    other tasks running now than the cores beside this one (a busy core would only split this session's
    share between the two: on the 2-core machine with one other session's job running the L = 30 case took
    12.5 s with the helper, 8.5 s without) -- and the candidates ``effects`` (None: all) on these check
    runs are work enough to pay for its start (:data:`HELPER_MIN_WORK`); else None (one after the other).
    Only where both processes compute alike: the helper has one BLAS thread, as the diagnosis of a small
    grid has (:mod:`identify.threads`), or the threads the user set for both."""
    grid = loaded.grid
    if not (single_threaded(grid.n_cells + 2) or user_chose_threads()):
        return None
    settings = sum(len(c.settings_grid()) for c in library(None if effects is None else
                                                           tuple(n for n in effects if n != "resolution")))
    if sum(len(run.rows) for run in loaded.check) * settings < HELPER_MIN_WORK:
        return None
    return helper_mapper(HELPER_MODULES)  # its imports overlap the base fit's


def _effects(text: str | None) -> tuple[str, ...] | None:
    if text is None:
        return None
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in NAMES]
    if unknown or not names:
        raise UserError(f"--with {text!r}: unknown effect(s) {', '.join(unknown) or '(none given)'}; "
                        f"choose from {', '.join(NAMES)}")
    return names


@click.command()
@click.option("--fit", "fit_paths", type=_PATH, multiple=True, required=True,
              help="Identification run (session or CSV trace) the model is fitted on; repeat for several.")
@click.option("--check", "check_paths", type=_PATH, multiple=True, required=True,
              help="Held-out check run(s) the model is judged on (more may follow as arguments).")
@click.argument("more_checks", nargs=-1, type=_PATH)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--out", "-o", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Write where.png (binned residuals before and after the chosen effect) and candidates.png here.")
@click.option("--levels", "-L", type=int, help="Grid of the model [the first identification session's].")
@click.option("--v-min", type=float, help="Lower end of the grid (V).")
@click.option("--v-max", type=float, help="Upper end of the grid (V).")
@click.option("--method", type=click.Choice(sorted(METHODS)), default="ls", show_default=True,
              help="Identification method of the base model.")
@click.option("--with", "effects", cls=AliasedOption, aliases=("--effects",), multiple=True,
              metavar="EFFECT[,EFFECT...]",
              help=f"Candidate library, comma-separated or repeated [all: {', '.join(NAMES)}].")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the block bootstrap.")
@click.option("--partial", is_flag=True, help="Accept partial sessions (not complete): use the points they hold.")
@click.option("--fit-curves", type=click.Choice(CURVE_CHOICES), default="all", show_default=True,
              help="Fit on the measured points of these curves only (runs made of curves, e.g. FORC).")
@click.option("--check-curves", type=click.Choice(CURVE_CHOICES), default="all", show_default=True,
              help="Judge on the measured points of these curves only; with --fit-curves even --check-curves odd "
                   "one FORC session serves as both.")
@click.option("--stride", type=int,
              help="Runs made of curves: use every K-th measured point of each curve [about 3000 points per run].")
@click.option("--discriminate", "plan_path", type=_PATH, metavar="PLAN.csv",
              help="When the verdict is not clear, write the follow-up run that tells the rivals apart "
                   "(v_V,dwell_s, for rig acquire --sequence PLAN.csv); nothing is written when it is clear.")
@click.option("--points", type=int, metavar="N",
              help=f"Most set-points the plan may hold [{DEFAULT_POINTS}; {MIN_POINTS} to {MAX_POINTS}].")
@click.option("--rig-time", "rig_time_s", type=float, metavar="S",
              help="Most rig time (s of dwell) the plan may take [the check run's].")
@click.option("--discriminate-on", "rig_config", type=_PATH, metavar="CONFIG",
              help="One step on the rig: acquire the plan as rig acquire --config CONFIG --sequence PLAN.csv "
                   "would, into PLAN.h5 (grid of the diagnosis, the check run's readings), and diagnose again "
                   "with it as one more check run; needs --discriminate.")
@click.option("--force", is_flag=True, help="Replace an existing PLAN.csv (and, with --discriminate-on, PLAN.h5).")
def diagnose(fit_paths, check_paths, more_checks, as_json, out_dir, levels, v_min, v_max, method, effects, seed,
             partial, fit_curves, check_curves, stride, plan_path, points, rig_time_s, rig_config, force):
    """Diagnose the sim-to-real gap of equation (22): fit on --fit, judge on --check.

    The model is identified on the identification run(s) only and judged on
    held-out check runs of a different input family (random reversals,
    several step sizes and dwells): where the residual stands out, which
    unmodelled effect explains it (thermal_lag, baseline_drift,
    ambient_drift, joule_power, creep, sensor_nonlinearity), and how far the
    gap shrinks with it.
    """
    asked = checked_request(plan_path, points, rig_time_s, force)
    session = checked_session(asked, rig_config)
    if session is not None:
        from drivers.config import load_config

        load_config(rig_config)  # a bad rig.toml is bad input: said now, before the diagnosis's work
    checks = list(check_paths) + list(more_checks)
    loaded = load_runs(list(fit_paths), checks, levels, v_min, v_max, allow_partial=partial,
                       fit_curves=fit_curves, check_curves=check_curves, stride=stride)
    settings = DiagnosisSettings(method=method, effects=_effects(",".join(effects) or None), seed=seed)
    mapper = _candidate_mapper(loaded, settings.effects)
    result = run_diagnosis(loaded.fit, loaded.check, loaded.grid, settings,
                           monitors=[np.asarray(m.output, dtype=float) for m in loaded.unique_monitors()],
                           mapper=mapper)
    fit_names = [str(p) + ("" if fit_curves == "all" else f":{fit_curves}") for p in fit_paths]
    check_names = [str(p) + ("" if check_curves == "all" else f":{check_curves}") for p in checks]
    agreement = drift_agreement(result, loaded)
    written = []
    if out_dir is not None:
        written = write_figures(result, out_dir)
    follow_up = plan_run(result, list(loaded.check), asked, seed) if asked is not None else None
    obj = to_json(result, fit_names, check_names, loaded.warnings, agreement) if as_json or session else None
    if as_json and written:
        obj["figures"] = [str(p) for p in written]
    if session is not None:
        follow_up.update(on=str(rig_config), session=None, acquisition=None, after=None, changed=None)
        if follow_up["plan"] is not None:
            follow_up["session"] = str(session)
    if not as_json:
        click.echo(to_text(result, fit_names, check_names, loaded.warnings, agreement))
        if follow_up is not None:
            click.echo(to_line(follow_up))
            if session is not None and follow_up["plan"] is None:
                click.echo("discriminate-on: nothing acquired (no plan was written)")
        for p in written:
            click.echo(f"wrote {p}")
    if session is not None and follow_up["plan"] is not None:
        obj["discriminate"] = follow_up
        _acquire_plan(Path(follow_up["plan"]), session, rig_config, loaded.grid,
                      readings_for(list(loaded.check)), follow_up, obj if as_json else None)
        again = load_runs(list(fit_paths), checks, loaded.grid.levels, loaded.grid.v_min, loaded.grid.v_max,
                          allow_partial=partial, fit_curves=fit_curves, check_curves=check_curves, stride=stride,
                          extra_checks=[session])
        second = run_diagnosis(again.fit, again.check, again.grid, settings,
                               monitors=[np.asarray(m.output, dtype=float) for m in again.unique_monitors()],
                               mapper=_candidate_mapper(again, settings.effects))
        again_names, again_agreement = check_names + [str(session)], drift_agreement(second, again)
        after = to_json(second, fit_names, again_names, again.warnings, again_agreement)
        follow_up.update(after=after, changed=changed(obj["verdict"], after["verdict"]))
        if not as_json:
            click.echo("")
            click.echo(f"after the discriminating run ({session}): {verdict_summary(after['verdict'])} "
                       f"(was {verdict_summary(obj['verdict'])})")
            click.echo(to_text(second, fit_names, again_names, again.warnings, again_agreement))
    if as_json:
        if follow_up is not None:
            obj["discriminate"] = follow_up
        print_json(obj)


def _acquire_plan(plan: Path, session: Path, rig_config: Path, grid, readings: int | None, follow_up: dict,
                  obj: dict | None) -> None:
    """Acquire ``plan`` into ``session`` exactly as ``rig acquire --config RIG_CONFIG --sequence PLAN
    --levels/--v-min/--v-max (the grid) --readings K --out SESSION`` does (same checks, cost line, sequencer,
    Ctrl-C, heater to 0 V, exit codes 3 and 130); the run's summary goes into ``follow_up["acquisition"]``
    and, in text (``obj`` None), is printed.  Aborted with ``--json``: ``obj`` is printed (no second
    diagnosis) before the exit 130."""
    from sessions import Status, read_session

    from rig.acquisition import summarise

    from .acquire import new_session, print_summary

    def report(outcome) -> None:
        summary = summarise(read_session(session), outcome)
        follow_up["acquisition"] = summary
        if obj is None:
            print_summary(summary, False)
        elif outcome.status is Status.ABORTED:
            print_json(obj)

    if session.exists() or session.is_symlink():  # --force, checked before the diagnosis
        session.unlink()
    kwargs = {} if readings is None else {"readings": int(readings)}
    new_session(rig_config, session, sequence=str(plan), levels=grid.levels, v_min=grid.v_min, v_max=grid.v_max,
                notes=f"rig diagnose --discriminate-on: the run that tells apart "
                      f"{' and '.join(follow_up['between'])}", report=report, **kwargs)
