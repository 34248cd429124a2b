"""``rig acquire``: run an excitation on the rig and record it as a session; ``--resume`` continues one."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np
from click.core import ParameterSource

from drivers.backends import setpoint_rules
from drivers.config import default_config, load_config
from identify.sequential import MIN_POINTS
from rig.acquisition import (
    AcquisitionError,
    AcquisitionPlan,
    RunOutcome,
    DwellSettings,
    FixedDwell,
    RateBelow,
    SettleDwell,
    Transit,
    acquire as run_acquisition,
    make_record,
    resume as resume_acquisition,
    sequence_dwells,
    sequence_record,
    summarise,
)
from rig.acquisition.recipe import default_recipe, given_recipe
from rig.acquisition.adaptive import (ADAPTIVE_METHOD, FIRST_DWELL_S, MAX_DWELL_S, MOST_POINTS_PER_UNKNOWN,
                                     AdaptiveSetpoints, adaptive_record, check_target, design_for)
from rig.acquisition.timed import CONTRADICTING, check_options, describe, reference_device, timed_plan
from rig.acquisition.runner import resumable
from rig.acquisition.sequence import DEFAULT_LEVELS, DEFAULT_RANDOM_POINTS, default_grid
from sessions import ADAPTIVE_COLUMNS, ADAPTIVE_KIND, DataFileError, IdentifyRecipe, read_session

from ..budget.acquisition import announce, planned_points, too_many_points
from ..budget.limits import format_duration, refuse_unless_confirmed
from ..options import AliasedOption
from ..output import print_json
from ..run_driver import config_for_resume, drive

#: Options that describe a new run; a resumed run takes all of them from its session.
PLAN_OPTIONS = ("sequence", "levels", "v_min", "v_max", "thermal_term", "points", "seed", "dwell", "dwells",
                "settle", "poll", "transit", "readings", "measure", "out", "operator", "notes", "identify_with",
                "rig_time", "target_nrmse")


def _given(ctx, names: tuple[str, ...]) -> list[str]:
    """The options among ``names`` (parameter names) the user gave, as spelled on the command line."""
    return [f"--{n.replace('_', '-')}" for n in names if ctx.get_parameter_source(n) is not ParameterSource.DEFAULT]


@dataclass(frozen=True)
class TimedRequest:
    """``--rig-time S`` (``budget_s``, s) and ``--readings`` when given (else the plan chooses); with
    ``--target-nrmse X`` (``target_nrmse``) the budget is the run's cap instead."""

    budget_s: float | None
    readings: int | None = None
    target_nrmse: float | None = None
    #: With ``target_nrmse``: ``--dwell`` when given, the run's first dwell (s; None: its own first dwell).
    first_dwell_s: float | None = None


def _settings(dwell: float, settle: float | None, poll: float, transit: float, readings: int,
              schedule=None) -> DwellSettings:
    policy = FixedDwell(dwell) if settle is None else SettleDwell(RateBelow(settle), dwell, poll, readings)
    return DwellSettings(policy, Transit(transit), readings, None if schedule is None else tuple(schedule))


def _dwell_choices(text: str | None) -> tuple[float, ...] | None:
    """``--dwells 8,15,30,60`` as seconds (finite, >= 0); None when not given."""
    if text is None:
        return None
    try:
        values = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise AcquisitionError(f"--dwells {text!r}: expected seconds separated by commas, e.g. 8,15,30,60") from None
    if not values or any(not (v == v and 0 <= v < float("inf")) for v in values):
        raise AcquisitionError(f"--dwells {text!r}: every dwell must be a finite number of seconds >= 0")
    return values


def print_summary(summary: dict, as_json: bool) -> None:
    """What a run did: `summary` (from :func:`~rig.acquisition.summarise`) as JSON, or in a few lines."""
    if as_json:
        print_json(summary)
        return
    s = summary
    click.echo(
        f"{s['session']}: {s['status']}, {s['n_applied']} of {s['n_points']} points applied, "
        f"{s['n_measured']} measured ({s['n_reversals']} reversal points), {s['n_timeouts']} dwell timeouts"
    )
    if s["resumed"]:
        click.echo(f"resumed: the memory state was restored by replaying {s['n_replayed']} points")
    if s["n_reconnected"]:
        click.echo(f"{s['n_reconnected']} point(s) measured across a reconnection of the link (flagged RECONNECTED; "
                   "the instrument was checked to be the same one holding the set-point)")
    if s["n_retried"]:
        click.echo(f"{s['n_retried']} point(s) needed a repeated reading (flagged READ_RETRIED: a failed, "
                   "mismatched, stale or out-of-range reply came first)")
    click.echo(f"rig time {format_duration(s['rig_time_s'])} on the {s['clock']} clock (wall {s['wall_s']:.3g} s)")
    if s["n_applied"] > s["n_measured"]:
        click.echo(
            f"compressive: measuring every point would take ~{format_duration(s['full_time_s'])}; "
            f"saved {format_duration(s['time_saved_s'])} ({100 * s['time_saved_fraction']:.0f}%)"
        )
    if s.get("identify_recipe"):
        click.echo(f"rig identify {s['session']} will use: {describe_recipe(s['identify_recipe'])}")


def describe_recipe(r: dict) -> str:
    """A stored identification recipe in a few words: ``ls, L=8 on [0, 6], thermal term, no effects``."""
    grid = "no grid" if r.get("levels") is None else f"L={r['levels']}"
    if r.get("v_min") is not None and r.get("v_max") is not None:
        grid += f" on [{r['v_min']:g}, {r['v_max']:g}]"
    thermal = "thermal term" if r.get("thermal_term", True) else "no thermal term"
    effects = ("with " + ",".join(r["effects"])) if r.get("effects") else "no effects"
    return f"{r['method']}, {grid}, {thermal}, {effects}"


@click.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="rig.toml (default: the built-in simulated device on a virtual clock; "
                   "with --resume: the configuration stored in the session).")
@click.option("--sequence", default="damped", show_default=True,
              help="damped (the damped oscillation), random (a validation input), check (a check run for "
                   "rig diagnose, with its own dwells), damped+check (both in one run: for rig identify --with) "
                   "or FILE.csv (a v_V column; an optional dwell_s column gives each point its own dwell).")
@click.option("--levels", "-L", type=int, help="Levels L of the grid [30; a FILE: none unless given].")
@click.option("--v-min", type=float, help="Lower end of the grid (V) [0, or a FILE's minimum].")
@click.option("--v-max", type=float, help="Upper end of the grid (V) [the heater's maximum, or a FILE's maximum].")
@click.option("--thermal-term/--no-thermal-term", default=True, show_default=True,
              help="damped: end with the thermal-term point.")
@click.option("--points", type=int, help="random, check: number of points [200].")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seed of the random sequence and of the choice of measured points.")
@click.option("--dwell", type=float, default=20.0, show_default=True,
              help="Wait at each measured point and reversal point (s); with --settle, the longest wait; "
                   "a FILE's dwell_s column overrides it point by point.")
@click.option("--dwells", metavar="S,S,...",
              help="damped, random: each point waits one of these dwells (s), drawn at random with --seed "
                   "(varied dwells identify a thermal lag; rig identify --with thermal_lag needs them).")
@click.option("--settle", type=float, metavar="RATE",
              help="Wait until the deflection changes by less than RATE um/s (at most --dwell s).")
@click.option("--poll", type=float, default=0.5, show_default=True, help="With --settle: seconds between checks.")
@click.option("--transit", type=float, default=0.0, show_default=True,
              help="Wait at points that are neither measured nor reversal points (s).")
@click.option("--readings", "-K", type=int, default=4, show_default=True, help="Readings averaged per measurement.")
@click.option("--measurements", "-M", "measure", cls=AliasedOption, aliases=("--measure",), type=int, metavar="M",
              help="Measure M points in all: every reversal point plus M-R chosen at random [all].")
@click.option("--out", "-o", type=click.Path(dir_okay=False, path_type=Path), help="Session file to create (HDF5).")
@click.option("--resume", "resume_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Continue this interrupted session instead (its plan and settings).")
@click.option("--rig-time", type=float, metavar="S",
              help="Plan the damped oscillation within S seconds of rig time: the dwells, readings and whether "
                   "to model the thermal transient instead of waiting it out, chosen for the least expected "
                   "error on a held-out run; the session records the recipe rig identify then uses.")
@click.option("--target-nrmse", type=float, metavar="X",
              help="Choose each next set-point from what was measured (I-optimal for the density) and stop when "
                   "the model's predicted check nRMSE reaches X (with --rig-time S: or at S seconds; --points: "
                   "the most points [2 x the unknowns]); the run finds its own dwell: it starts at --dwell [1 s] and "
                   "doubles it whenever a repeated point shows the beam had not settled (--settle: the settle "
                   "condition decides each wait instead).")
@click.option("--identify-with", metavar="METHOD[:EFFECT,...]",
              help="Record in the session that it is to be identified with this method (and these effects, "
                   "as rig identify --with); rig identify uses it unless told otherwise "
                   "[ls on the run's grid, no effects].")
@click.option("--operator", default="", help="Who runs the acquisition.")
@click.option("--notes", default="", help="Free-text notes stored with the session.")
@click.option("--progress/--no-progress", default=None, help="Progress bar on stderr [when stderr is a terminal].")
@click.option("--yes", is_flag=True, help="Run a plan above the documented limits (1,000,000 points; a week of "
                                          "rig time on a real clock) after all.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.pass_context
def acquire(ctx, config_path, sequence, levels, v_min, v_max, thermal_term, points, seed, dwell, dwells, settle, poll,
            transit, readings, measure, out, resume_path, rig_time, target_nrmse, identify_with, operator, notes,
            progress, yes, as_json):
    """Apply an excitation on the rig and record every point in the session OUT.

    Without --config this runs on the simulated device and its virtual
    clock, in seconds.  Ctrl-C once pauses at a safe point (heater held) and
    asks to resume or abort -- without a terminal it aborts there; twice
    aborts at once.  Abort or error: heater to 0 V, session kept;
    `rig acquire --resume OUT` restores the memory state and continues.
    The session records how it is to be identified (see --identify-with),
    which `rig identify OUT` uses.
    """
    if resume_path is not None:
        given = _given(ctx, PLAN_OPTIONS)
        if given:
            raise AcquisitionError(f"--resume continues the session's own plan; {', '.join(given)} cannot be used with it")
        session = resumable(resume_path)
        if session.excitation.kind == ADAPTIVE_KIND:
            raise AcquisitionError(f"{resume_path}: a run to a target error cannot be resumed (its next set-points "
                                   "depend on a design state that is not stored); rig identify reads the points "
                                   "it has, and a new --target-nrmse run starts afresh")
        cfg = config_for_resume(config_path, session)
        target, total, start = resume_path, session.excitation.n_points, session.n_samples

        def run(rig, hooks):
            return resume_acquisition(rig, resume_path, hooks=hooks)

        drive(cfg, target, total, start, progress, run,
              lambda outcome: print_summary(summarise(read_session(target), outcome), as_json), "rig acquire")
        return
    if out is None:
        raise AcquisitionError("give --out S.h5 for a new session, or --resume S.h5 to continue one")
    timed = None
    if target_nrmse is not None:
        given = _given(ctx, ADAPTIVE_CONTRADICTING)
        if sequence != "damped" or given:
            raise AcquisitionError("--target-nrmse chooses the set-points and the recipe itself; "
                                   f"{', '.join(given) or '--sequence ' + sequence} contradicts it")
        timed = TimedRequest(rig_time, None, target_nrmse, dwell if ctx.get_parameter_source("dwell")
                             is not ParameterSource.DEFAULT else None)
    elif rig_time is not None:
        check_options(sequence, _given(ctx, CONTRADICTING))
        timed = TimedRequest(rig_time, readings if ctx.get_parameter_source("readings")
                             is not ParameterSource.DEFAULT else None)
    new_session(config_path, out, sequence=sequence, levels=levels, v_min=v_min, v_max=v_max,
                thermal_term=thermal_term, points=points, seed=seed, dwell=dwell, dwells=dwells, settle=settle,
                poll=poll, transit=transit, readings=readings, measure=measure, operator=operator, notes=notes,
                progress=progress, yes=yes, identify_with=identify_with, timed=timed,
                report=lambda outcome: print_summary(summarise(read_session(out), outcome), as_json))


def new_session(config_path: Path | None, out: Path, *, sequence: str = "damped", levels: int | None = None,
                v_min: float | None = None, v_max: float | None = None, thermal_term: bool = True,
                points: int | None = None, seed: int = 0, dwell: float = 20.0, dwells: str | None = None,
                settle: float | None = None, poll: float = 0.5, transit: float = 0.0, readings: int = 4,
                measure: int | None = None, operator: str = "", notes: str = "", progress: bool | None = None,
                yes: bool = False, report: Callable[[RunOutcome], None] | None = None,
                identify_with: str | None = None, timed: "TimedRequest | None" = None) -> RunOutcome:
    """``rig acquire --config CONFIG_PATH --out OUT ...`` (a new run; the keywords are its options, with
    its defaults): build and check the plan, state its cost on stderr, open the rig, run, and end as
    :func:`~rig.run_driver.drive` does (heater to 0 V; aborted: exit 130; a fault: exit 3).
    ``report(outcome)`` prints the summary (default: nothing).  The session records its identification
    recipe: :func:`~rig.acquisition.recipe.default_recipe`, or ``identify_with``'s method and effects
    (``METHOD[:EFFECT,...]``).  Other commands that acquire a run
    (``rig diagnose --discriminate-on``) call this, so their runs are acquisitions like any other.
    ``timed`` (``--rig-time``): the plan within its budget sets the dwells, the readings and the recipe
    (:mod:`rig.acquisition.timed`), and is stated on stderr before the rig is touched."""
    if out.exists() or out.is_symlink():
        raise DataFileError(f"{out}: already exists; a session is never overwritten")
    cfg = load_config(config_path) if config_path else default_config()
    rules = setpoint_rules(cfg)
    window = rules.window
    refuse_unless_confirmed("rig acquire", too_many_points(planned_points(  # before building it
        sequence, levels, points, thermal_term, DEFAULT_LEVELS, DEFAULT_RANDOM_POINTS)), yes)
    if timed is not None and timed.target_nrmse is not None:
        return _to_target(cfg, out, timed, window=window, rules=rules, levels=levels, v_min=v_min, v_max=v_max,
                          thermal_term=thermal_term, points=points, seed=seed, dwell=dwell, settle=settle, poll=poll,
                          readings=readings, operator=operator, notes=notes, progress=progress, report=report)
    if timed is not None:
        plan = timed_plan(cfg, default_grid(window, levels, v_min, v_max), timed.budget_s,
                          thermal_term=thermal_term, readings=timed.readings, seed=seed)
        click.echo(describe(plan), err=True)
        schedule, readings, dwell = plan.dwell_s, plan.readings, float(plan.dwell_s.max())
        identify_with = ":".join(["ls", ",".join(plan.effects)]) if plan.effects else "ls"
    else:
        schedule = sequence_dwells(sequence, window, levels=levels, v_min=v_min, v_max=v_max, points=points,
                                   seed=seed, thermal_term=thermal_term, dwell=dwell, choices=_dwell_choices(dwells))
    settings = _settings(dwell, settle, poll, transit, readings, schedule)
    record = make_record(
        sequence_record(sequence, window, levels=levels, v_min=v_min, v_max=v_max, points=points,
                        seed=seed, thermal_term=thermal_term),
        settings, measure, seed,
    )
    if timed is not None:  # the plan is kept with the session: what was chosen, and from what
        record = dataclasses.replace(record, extra={**record.extra, "rig_time_plan": plan.as_dict()})
    recipe = default_recipe(record) if identify_with is None else given_recipe(identify_with, record)
    if timed is not None:
        recipe = dataclasses.replace(recipe, reason=f"rig acquire --rig-time {timed.budget_s:g}: "
                                                    + ("the plan models the thermal transient" if plan.effects
                                                       else "the plan waits the transient out"))
    plan = AcquisitionPlan.from_record(record)
    plan.check_window(window, rules.check)  # before the rig is touched
    announce(plan, dwell, transit, settings.schedule, settle is not None, cfg.clock_kind == "virtual", yes)

    def run(rig, hooks):
        return run_acquisition(rig, record, out, settings=settings, operator=operator, notes=notes, hooks=hooks,
                               recipe=recipe)

    return drive(cfg, out, record.n_points, 0, progress, run, report or (lambda outcome: None), "rig acquire")


#: Options a run to a target error chooses itself (given with --target-nrmse: exit 2).
ADAPTIVE_CONTRADICTING = ("dwells", "measure", "identify_with", "transit")


def _to_target(cfg, out: Path, timed: TimedRequest, *, window, rules, levels, v_min, v_max, thermal_term, points,
               seed, dwell, settle, poll, readings, operator, notes, progress, report) -> RunOutcome:
    """``rig acquire --target-nrmse X``: a run whose set-points are chosen as it goes
    (:mod:`rig.acquisition.adaptive`), recorded like any run, ended when the target is predicted."""
    grid = default_grid(window, levels, v_min, v_max)
    first = None if settle is not None else (FIRST_DWELL_S if timed.first_dwell_s is None else timed.first_dwell_s)
    if first is not None and not (0 < first <= MAX_DWELL_S):
        raise AcquisitionError(f"--dwell {first:g}: a run to a target starts from a dwell above 0 and at most "
                               f"{MAX_DWELL_S:g} s (it lengthens the dwell itself)")
    dwell = dwell if first is None else first
    design = design_for(cfg, grid, (max(window.min_V, grid.v_min), min(window.max_V, grid.v_max)), readings, seed,
                        thermal_term, dwell_s=first)
    ref = reference_device(cfg, grid)
    span = float(np.ptp(design.check @ ref.parameters(thermal_term)))
    check_target(timed.target_nrmse, design, span)
    if timed.budget_s is not None and not (timed.budget_s > 0 and np.isfinite(timed.budget_s)):
        raise AcquisitionError(f"--rig-time must be a positive number of seconds, got {timed.budget_s:g}")
    unknowns = grid.n_cells + 1 + int(thermal_term)
    most = MOST_POINTS_PER_UNKNOWN * unknowns if points is None else int(points)
    if most < MIN_POINTS:
        raise AcquisitionError(f"--points {most}: a run to a target needs at least {MIN_POINTS} points")
    settings = _settings(dwell, settle, poll, 0.0, readings)
    record = make_record(adaptive_record(grid, most, thermal_term, seed, timed.target_nrmse, timed.budget_s,
                                         first), settings, None, seed)
    recipe = IdentifyRecipe(method=ADAPTIVE_METHOD, levels=grid.levels, v_min=grid.v_min, v_max=grid.v_max,
                            effects=(), thermal_term=thermal_term,
                            reason=f"rig acquire --target-nrmse {timed.target_nrmse:g}: the prediction is about "
                                   f"{ADAPTIVE_METHOD}'s smooth, non-negative density")
    cap = "" if timed.budget_s is None else f", at most {format_duration(timed.budget_s)} of rig time"
    waits = (f"of {dwell:g} s (or settled sooner)" if first is None else
             f"waiting {first:g} s at first, twice as long whenever settle replicates show the points were not "
             f"at rest (at most {MAX_DWELL_S:g} s)")
    click.echo(f"run to a target: check nRMSE {timed.target_nrmse:g} predicted from the model's uncertainty "
               f"(checked on random check points and replicates); at most {most} points {waits}{cap}", err=True)

    def say(k: int, predicted: float, t_s: float) -> None:
        click.echo(f"point {k}: predicted check nRMSE {predicted:.3g} (target {timed.target_nrmse:g}), "
                   f"rig time {format_duration(t_s)}", err=True)

    def longer(k: int, old: float, new: float) -> None:
        gone = int((~design.kept & np.isfinite(design.outputs)).sum())
        click.echo(f"point {k}: not at rest after {old:g} s (settle replicates); the dwell is now {new:g} s; "
                   f"{gone} point{'' if gone == 1 else 's'} measured at shorter dwells stay in the session, "
                   "not fitted", err=True)

    source = AdaptiveSetpoints(design, timed.target_nrmse, timed.budget_s, dwell, report=say, lengthened=longer)

    def run(rig, hooks):
        return run_acquisition(rig, record, out, settings=settings, operator=operator, notes=notes, hooks=hooks,
                               setpoints=source, sample_columns=ADAPTIVE_COLUMNS, recipe=recipe)

    def done(outcome):
        click.echo(f"ended: {source.reason} (predicted check nRMSE {source.predicted:.3g})", err=True)
        (report or (lambda o: None))(outcome)

    return drive(cfg, out, record.n_points, 0, progress, run, done, "rig acquire")
