"""``rig report``: figures and a Markdown summary of a session and its model."""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import UserError
from ..options import AliasedOption
from ..output import print_json
from ..session_input import choose_model, open_run, session_of


def default_out(session: Path) -> Path:
    """``run1.h5`` -> ``run1-report`` beside it."""
    return session.with_name(f"{session.stem}-report")


@click.command()
@click.argument("session", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "-o", "out_dir", type=click.Path(path_type=Path),
              help="Directory for the figures and report.md (default: SESSION's name + '-report', beside it).")
@click.option("--model", "model_name", help="Stored model to show (default: the most recently stored).")
@click.option("--check", "validation", cls=AliasedOption, aliases=("--validate",),
              type=click.Path(dir_okay=False, path_type=Path), metavar="RUN",
              help="Also show the model against this run (a session or CSV trace), e.g. a random-input run.")
@click.option("--partial", is_flag=True, help="Accept partial sessions (the points they hold).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def report(session, out_dir, model_name, validation, partial, as_json):
    """Write PNG figures and a Markdown summary of SESSION and a model stored in it.

    Figures: input and output against time, the hysteresis loop (measured
    and model), the identified density on the Preisach triangle, and the
    residual against input by branch; the same for --check's run. The
    session is only read; report files already in the directory are
    replaced, other files left alone.
    """
    # matplotlib is imported here, not when the rig command starts
    from ..session_report import SUMMARY, build_report, score_runs, write_report

    data = open_run(session, allow_partial=partial)
    record = choose_model(session_of(data, "rig report"), model_name)
    v_data = None if validation is None else open_run(validation, allow_partial=partial)
    fitted, checked = score_runs(record, data, v_data)
    built = build_report(fitted, record, checked)  # every check and figure before writing anything
    out = default_out(session) if out_dir is None else out_dir
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a directory")
    written = write_report(built, out)
    result = {
        "session": str(session),
        "model": record.name,
        "out": str(out),
        "summary": str(out / SUMMARY),
        "figures": [str(p) for p in written if p.suffix == ".png"],
        "rmse": fitted.score.rmse,
        "nrmse": fitted.score.nrmse,
        "validation": None if checked is None else {
            "on": str(validation),
            "rmse": checked.score.rmse,
            "max_abs": checked.score.max_abs,
            "nrmse": checked.score.nrmse,
        },
        "output_unit": data.output_unit,
    }
    if as_json:
        print_json(result)
        return
    click.echo(f"{out / SUMMARY}: report of {session} with model {record.name!r} ({record.method}), "
               f"{len(result['figures'])} figures")
