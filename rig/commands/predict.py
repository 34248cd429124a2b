"""``rig predict``: apply a saved model to a trace."""

from __future__ import annotations

import json
from pathlib import Path

import click

import numpy as np

from identify import PreisachModel
from identify.metrics import max_abs, rmse

from ..errors import UserError
from ..output import format_table, print_json
from ..session_input import open_run, run_of


def load_model(path: Path) -> PreisachModel:
    """A model from a JSON file written by ``rig identify --json`` or ``--save``."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: cannot read the model ({exc})") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}: not a JSON model (line {exc.lineno}: {exc.msg})") from None
    try:
        return PreisachModel.from_dict(data)
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None


@click.command()
@click.argument("model_file", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def predict(model_file, file, as_json):
    """Predict the deflection of FILE (a CSV trace, or a session) with the model in MODEL_FILE.

    The memory starts in negative saturation; RMSE and maximum error are
    against the run's measured deflection. A model with effects acts on
    the whole run (its time stamps, and a session's dwells); an effect that
    needs what the run does not record is refused.
    """
    model = load_model(model_file)
    data = open_run(file, allow_partial=True)
    if model.effects:
        prediction = model.predict_run(run_of(data))
    else:
        prediction = model.predict(data.inputs)
    measured = np.isfinite(data.outputs)
    err = prediction[measured] - data.outputs[measured]
    result = {"prediction_um": prediction, "rmse_um": rmse(err), "max_abs_um": max_abs(err)}
    if as_json:
        print_json(result)
        return
    click.echo(f"{file}: {prediction.size} points predicted with {model_file}")
    click.echo(format_table(["rmse_um", "max_abs_um"], [[result["rmse_um"], result["max_abs_um"]]]))
