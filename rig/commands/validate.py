"""``rig validate``: score a model stored in one session on another recorded run."""

from __future__ import annotations

from pathlib import Path

import click

from ..curve_selection import CURVE_CHOICES, selected_rows
from ..options import AliasedOption
from ..output import format_table, print_json, unit_token
from ..model_scoring import score_model
from ..session_input import choose_model, open_run, session_of


@click.command()
@click.argument("session", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--model", "model_name", help="Stored model to use (default: the most recently stored).")
@click.option("--check", "run", cls=AliasedOption, aliases=("--on",), required=True,
              type=click.Path(dir_okay=False, path_type=Path), metavar="RUN",
              help="The run to predict: a session (or CSV trace), e.g. a random-input validation run.")
@click.option("--partial", is_flag=True, help="Accept a partial validation session (the points it holds).")
@click.option("--curves", type=click.Choice(CURVE_CHOICES), default="all", show_default=True,
              help="Compare on the measured points of these curves only (numbered from 0); every applied point "
                   "still sets the memory state.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def validate(session, model_name, run, partial, curves, as_json):
    """Apply the model stored in SESSION to the run given with --check and report its errors.

    The memory starts in negative saturation; every applied point of the
    run is predicted and compared where it was measured (on the selected
    curves). Nothing is written.
    """
    source = session_of(open_run(session, allow_partial=True), "rig validate")
    record = choose_model(source, model_name)
    data = open_run(run, allow_partial=partial)
    result = score_model(record, data, rows=selected_rows(data, curves))
    g = record.model.grid
    summary = {
        "session": str(session),
        "model": record.name,
        "method": record.method,
        "on": str(run),
        "levels": g.levels,
        "v_min": g.v_min,
        "v_max": g.v_max,
        "n_points": result.n_points,
        "n_measured": result.n_measured,
        "n": result.n_measured,
        "curves": curves,
        "rmse": result.rmse,
        "max_abs": result.max_abs,
        "nrmse": result.nrmse,
        "output_range": result.output_range,
        "input_unit": data.input_unit,
        "output_unit": data.output_unit,
        "effects": [e.name for e in record.model.effects],
        **({"nuisance": result.nuisance} if result.nuisance else {}),
    }
    if as_json:
        print_json(summary)
        return
    u = unit_token(data.output_unit)
    click.echo(f"{run}: {result.n_points} points predicted with model {record.name!r} ({record.method}, "
               f"L={g.levels}) of {session}")
    click.echo(format_table(["measured", f"rmse_{u}", f"max_abs_{u}", "nrmse"],
                            [[result.n_measured, result.rmse, result.max_abs, result.nrmse]]))
