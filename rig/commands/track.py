"""``rig track``: drive the rig so that the deflection follows a target, through a model's inverse."""

from __future__ import annotations

from pathlib import Path

import click
from click.core import ParameterSource

from drivers.backends import setpoint_rules
from drivers.config import default_config, load_config
from identify.inverse import FEEDBACKS
from rig.acquisition import AcquisitionError, AcquisitionPlan, acquire as run_acquisition, resume as resume_run
from rig.acquisition.runner import resumable
from sessions import DataFileError, TRACKING_COLUMNS, read_session
from sessions.convert import sha256_of
from sessions.targets import read_targets

from ..budget.acquisition import announce
from ..output import format_table, print_json
from ..run_driver import config_for_resume, drive
from ..tracking.run import plan_track, setpoints_for, summary, track_settings
from ..tracking.source import ModelSource, check_targets, check_units, check_window, load_source

#: Options that describe a new run; a resumed run takes all of them from its session.
PLAN_OPTIONS = ("source", "target", "out", "model_name", "feedback", "dwell", "saturate", "readings", "operator",
                "notes")


#: Exit code of a tracking run that completed but missed far beyond its model (docs/reference/exit-codes.md).
EXIT_TRACKING_OFF = 4


def _report(result: dict, as_json: bool) -> None:
    if as_json:
        print_json(result)
    else:
        _print(result)
    if result["warning"] is not None and result["status"] == "complete":
        click.echo(f"warning: {result['warning']}", err=True)
        raise click.exceptions.Exit(EXIT_TRACKING_OFF)


def _print(result: dict) -> None:
    r = result
    click.echo(f"{r['session']}: {r['status']}, {r['n']} of {r['n_points']} targets measured; feedback {r['feedback']}; "
               f"model {r['model']!r} of {r['source']}")
    click.echo(format_table(["rmse_um", "max_abs_um", "nrmse", "unreachable", "model_rmse_um"],
                            [[r["rmse_um"], r["max_abs_um"], r["nrmse"], r["unreachable"], r["model_rmse_um"]]]))
    click.echo(f"baseline: the linear inverse of the model's major loop would give rmse "
               f"{r['baseline']['linear_inverse_rmse_um']:.4g} um on these targets (predicted by the model)")
    if "repetitions_rmse_um" in r:
        click.echo("rmse by repetition (um): " + ", ".join(f"{x:.4g}" for x in r["repetitions_rmse_um"]))


@click.command()
@click.argument("source", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--target", type=click.Path(dir_okay=False, path_type=Path),
              help="Target file: t_s,target_um (each target is read at its time; the step before it is its dwell).")
@click.option("--out", "-o", type=click.Path(dir_okay=False, path_type=Path), help="Session file to create (HDF5).")
@click.option("--model", "model_name", help="With a session as SOURCE: the stored model (default: the most recent).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="rig.toml (default: the built-in simulated device on a virtual clock; with --resume: the "
                   "configuration stored in the session).")
@click.option("--feedback", type=click.Choice(FEEDBACKS), default="none", show_default=True,
              help="none (the inverse alone), pi (a correction from the measured deflection), ilc (learned over "
                   "the repetitions of a periodic target).")
@click.option("--dwell", type=float, help="Wait at every point (s) [each target's time step].")
@click.option("--saturate", type=float, default=20.0, show_default=True,
              help="Wait at 0 V before the first point (s): negative saturation, the model's starting state.")
@click.option("--readings", "-K", type=int, default=4, show_default=True, help="Readings averaged per measurement.")
@click.option("--resume", "resume_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Continue this interrupted tracking session instead (its model, targets and feedback).")
@click.option("--operator", default="", help="Who runs it.")
@click.option("--notes", default="", help="Free-text notes stored with the session.")
@click.option("--progress/--no-progress", default=None, help="Progress bar on stderr [when stderr is a terminal].")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.pass_context
def track(ctx, source, target, out, model_name, config_path, feedback, dwell, saturate, readings, resume_path,
          operator, notes, progress, as_json):
    """Drive the rig so that the deflection follows the targets in --target, through the inverse of the model in SOURCE.

    SOURCE is a session holding the model (--model NAME) or a model JSON
    file. Each set-point is the model's inverse, from the memory state the
    run has reached, of the target (with --feedback pi or ilc: corrected by
    the deflections measured so far); the sequencer applies it with the
    safety, dwell, pause and resume of rig acquire, and the session records
    target, commanded voltage, predicted and measured deflection. Without
    --config it runs on the simulated device and its virtual clock.
    """
    if resume_path is not None:
        given = [f"--{n.replace('_name', '').replace('_', '-')}" if n != "source" else "SOURCE" for n in PLAN_OPTIONS
                 if ctx.get_parameter_source(n) is not ParameterSource.DEFAULT]
        if given:
            raise AcquisitionError(f"--resume continues the session's own targets, model and feedback; "
                                   f"{', '.join(given)} cannot be used with it")
        session = resumable(resume_path, tracking=True)
        cfg = config_for_resume(config_path, session)
        settings = track_settings(session)
        model = session.models[settings["model"]].model
        setpoints = setpoints_for(session, model, resume_path.stem)
        target_path, total, start = resume_path, session.excitation.n_points, session.n_samples

        def run(rig, hooks):
            return resume_run(rig, resume_path, hooks=hooks, setpoints=setpoints)
    else:
        if source is None or target is None or out is None:
            raise AcquisitionError("give SOURCE, --target TARGET.csv and --out T.h5 for a new tracking run, or "
                                   "--resume T.h5 to continue one")
        if out.exists() or out.is_symlink():
            raise DataFileError(f"{out}: already exists; a session is never overwritten")
        cfg = load_config(config_path) if config_path else default_config()
        rules = setpoint_rules(cfg)
        window = rules.window
        src: ModelSource = load_source(source, model_name)
        check_units(src)
        check_window(src, window.min_V, window.max_V)
        targets = read_targets(target)
        domain = (window.min_V, window.max_V)
        check_targets(src, targets, domain, target)
        plan = plan_track(src, targets, feedback, domain, dwell_s=dwell, saturate_s=saturate, readings=readings,
                          target_file={"name": target.name, "sha256": sha256_of(target)})
        acq = AcquisitionPlan.from_record(plan.record)
        acq.check_window(window, rules.check)  # the feed-forward plan, as the wire carries it
        announce(acq, saturate, 0.0, plan.settings.schedule, False, cfg.clock_kind == "virtual", True)
        model = src.model
        setpoints = setpoints_for(plan, model, out.stem)
        target_path, total, start = out, plan.record.n_points, 0

        def run(rig, hooks):
            return run_acquisition(rig, plan.record, out, settings=plan.settings, operator=operator, notes=notes,
                                   hooks=hooks, setpoints=setpoints, sample_columns=TRACKING_COLUMNS,
                                   models=(src.record,))

    drive(cfg, target_path, total, start, progress, run,
          lambda outcome: _report(summary(read_session(target_path), model), as_json), "rig track")

