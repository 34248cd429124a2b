"""``rig acquire``: run an excitation on the rig and record it as a session; ``--resume`` continues one."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from click.core import ParameterSource

from drivers.backends import setpoint_rules
from drivers.config import RigConfig, default_config, load_config, parse_config
from drivers.errors import CodecError, ConfigError, DriverError, LimitError, SafeStateError, SetpointRefused
from drivers.protocols import SafeState
from drivers.rig import open_rig
from rig.acquisition import (
    AcquisitionError,
    AcquisitionPlan,
    DwellSettings,
    FixedDwell,
    Hooks,
    PauseSwitch,
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
from rig.acquisition.progress import ProgressBar, format_duration, terminal_prompt
from rig.acquisition.runner import resumable
from rig.acquisition.sequence import DEFAULT_LEVELS, DEFAULT_RANDOM_POINTS
from sessions import DataFileError, Session, Status, StorageError, read_session

from ..budget.acquisition import announce, planned_points, too_many_points
from ..budget.limits import refuse_unless_confirmed
from ..errors import RigFault
from ..output import print_json

#: Exit code of a run aborted by the operator (as for Ctrl-C everywhere in ``rig``).
EXIT_ABORTED = 130

#: Options that describe a new run; a resumed run takes all of them from its session.
PLAN_OPTIONS = ("sequence", "levels", "v_min", "v_max", "thermal_term", "points", "seed", "dwell", "dwells",
                "settle", "poll", "transit", "readings", "measure", "out", "operator", "notes")


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


def _config_for_resume(config_path: Path | None, session: Session) -> RigConfig:
    if config_path is not None:
        return load_config(config_path)
    if not session.rig_config:
        raise AcquisitionError(f"{session.path}: no rig configuration stored; give --config")
    try:
        return parse_config(session.rig_config, f"{session.path} (stored rig configuration)")
    except ConfigError as exc:
        raise ConfigError(f"{exc}; give --config") from None


def _report(summary: dict, as_json: bool) -> None:
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
    click.echo(f"rig time {format_duration(s['rig_time_s'])} on the {s['clock']} clock (wall {s['wall_s']:.3g} s)")
    if s["n_applied"] > s["n_measured"]:
        click.echo(
            f"compressive: measuring every point would take ~{format_duration(s['full_time_s'])}; "
            f"saved {format_duration(s['time_saved_s'])} ({100 * s['time_saved_fraction']:.0f}%)"
        )


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
@click.option("--measure", "-M", type=int,
              help="Measure M points in all: every reversal point plus M-R chosen at random [all].")
@click.option("--out", "-o", type=click.Path(dir_okay=False, path_type=Path), help="Session file to create (HDF5).")
@click.option("--resume", "resume_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Continue this interrupted session instead (its plan and settings).")
@click.option("--operator", default="", help="Who runs the acquisition.")
@click.option("--notes", default="", help="Free-text notes stored with the session.")
@click.option("--progress/--no-progress", default=None, help="Progress bar on stderr [when stderr is a terminal].")
@click.option("--yes", is_flag=True, help="Run a plan above the documented limits (1,000,000 points; a week of "
                                          "rig time on a real clock) after all.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.pass_context
def acquire(ctx, config_path, sequence, levels, v_min, v_max, thermal_term, points, seed, dwell, dwells, settle, poll,
            transit, readings, measure, out, resume_path, operator, notes, progress, yes, as_json):
    """Apply an excitation on the rig and record every point in the session OUT.

    Without --config this runs on the simulated device and its virtual
    clock, in seconds.  Ctrl-C once pauses at a safe point (heater held) and
    asks to resume or abort -- without a terminal it aborts there; twice
    aborts at once.  Abort or error: heater to 0 V, session kept;
    `rig acquire --resume OUT` restores the memory state and continues.
    """
    if resume_path is not None:
        given = [f"--{n.replace('_', '-')}" for n in PLAN_OPTIONS
                 if ctx.get_parameter_source(n) is not ParameterSource.DEFAULT]
        if given:
            raise AcquisitionError(f"--resume continues the session's own plan; {', '.join(given)} cannot be used with it")
        session = resumable(resume_path)
        cfg = _config_for_resume(config_path, session)
        target, total, start = resume_path, session.excitation.n_points, session.n_samples
    else:
        if out is None:
            raise AcquisitionError("give --out S.h5 for a new session, or --resume S.h5 to continue one")
        if out.exists() or out.is_symlink():
            raise DataFileError(f"{out}: already exists; a session is never overwritten")
        cfg = load_config(config_path) if config_path else default_config()
        rules = setpoint_rules(cfg)
        window = rules.window
        refuse_unless_confirmed("rig acquire", too_many_points(planned_points(  # before building it
            sequence, levels, points, thermal_term, DEFAULT_LEVELS, DEFAULT_RANDOM_POINTS)), yes)
        schedule = sequence_dwells(sequence, window, levels=levels, v_min=v_min, v_max=v_max, points=points, seed=seed,
                                   thermal_term=thermal_term, dwell=dwell, choices=_dwell_choices(dwells))
        settings = _settings(dwell, settle, poll, transit, readings, schedule)
        record = make_record(
            sequence_record(sequence, window, levels=levels, v_min=v_min, v_max=v_max, points=points,
                            seed=seed, thermal_term=thermal_term),
            settings, measure, seed,
        )
        plan = AcquisitionPlan.from_record(record)
        plan.check_window(window, rules.check)  # before the rig is touched
        announce(plan, dwell, transit, settings.schedule, settle is not None, cfg.clock_kind == "virtual", yes)
        target, total, start = out, record.n_points, 0

    bar = ProgressBar(total, start, enabled=sys.stderr.isatty() if progress is None else progress)
    switch = PauseSwitch()
    hooks = Hooks(switch, terminal_prompt(bar), bar.update)
    rig = None
    try:
        with switch.installed(linger=True), open_rig(cfg) as rig:
            if resume_path is not None:
                outcome = resume_acquisition(rig, resume_path, hooks=hooks)
            else:
                outcome = run_acquisition(rig, record, out, settings=settings, operator=operator, notes=notes,
                                          hooks=hooks)
    except (DriverError, StorageError) as exc:
        bar.close()
        if rig is None or rig.heater_state is None or not target.exists():
            raise  # nothing was driven, or the session was never created: the error says it all
        after = _after_fault(target, rig.heater_state, exc)
        raise RigFault(after if isinstance(exc, SafeStateError) else f"{exc} -- {after}") from None
    except KeyboardInterrupt as exc:  # an abort outside the run itself (opening the rig, closing it)
        bar.close()
        heater = rig.heater_state if rig is not None else None
        said = heater.describe() if heater is not None else "the heater was not driven"
        kept = ""
        if target.exists() and rig is not None:
            s = read_session(target)
            kept = f"; session {target} is {s.status.value} with {s.n_samples} of {s.excitation.n_points} points kept"
        click.echo(f"aborted ({str(exc) or 'interrupted'}): {said}{kept}", err=True)
        raise click.exceptions.Exit(EXIT_ABORTED) from None
    bar.close()
    _report(summarise(read_session(target), outcome), as_json)
    if outcome.status is Status.ABORTED:
        click.echo(
            f"aborted ({outcome.message}): {rig.heater_state.describe()}; every sample kept; "
            f"{_resume_advice(target, rig.heater_state)}", err=True,
        )
        raise click.exceptions.Exit(EXIT_ABORTED)
    if not rig.heater_state.confirmed:  # complete, but the heater could not be confirmed at 0 V
        raise RigFault(_after_fault(target, rig.heater_state))


def _resume_advice(target: Path, heater: SafeState, fault: BaseException | None = None) -> str:
    if isinstance(fault, (SetpointRefused, LimitError, CodecError)):
        return ("the plan cannot be completed on this rig as configured (--resume would fail the same way): "
                "fix [heater] in rig.toml (max_V, max_current_mA, full_scale_V) or the plan, and start a new run")
    if not heater.confirmed:
        return f"once the bench is safe and the instrument answers, continue with: rig acquire --resume {target}"
    if isinstance(fault, StorageError):
        return f"free space (or mend the disk), then continue with: rig acquire --resume {target}"
    return f"continue with: rig acquire --resume {target}"


def _after_fault(target: Path, heater: SafeState, fault: BaseException | None = None) -> str:
    """What a fault left behind, in one clause: the heater as known, the session, and what to do."""
    try:
        s = read_session(target)
    except DataFileError as exc:
        return f"{heater.describe()}; the session cannot be read back ({exc})"
    kept = f"session {target} is {s.status.value} with {s.n_samples} of {s.excitation.n_points} points kept"
    if s.status is Status.COMPLETE:
        return f"{heater.describe()}; {kept}"
    return f"{heater.describe()}; {kept}; {_resume_advice(target, heater, fault)}"
