"""``rig predict``: apply a saved model (a JSON model file) to a recorded run, a session or a CSV trace."""

from __future__ import annotations

from pathlib import Path

import click

import numpy as np

from identify.metrics import max_abs, rmse

from ..errors import UserError
from ..model_file import load_model
from ..output import format_table, print_json, unit_token
from ..session_input import open_run, run_of


@click.command()
@click.argument("model_file", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--partial", is_flag=True, help="Accept a partial session (the points it holds).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def predict(model_file, file, partial, as_json):
    """Predict the output of FILE (a session or a CSV trace) with the model in MODEL_FILE.

    Every applied input of FILE is predicted, the memory starting in
    negative saturation; RMSE and maximum error are over the points where
    FILE measured the output (for a CSV trace, every row). A model with
    effects acts on the whole run (its time stamps, and a session's
    dwells); an effect that needs what the run does not record is refused.
    """
    model = load_model(model_file)
    data = open_run(file, allow_partial=partial)
    if (model.input_unit, model.output_unit) != (data.input_unit, data.output_unit):
        raise UserError(f"{file}: records {data.input_unit} in and {data.output_unit} out, but the model in "
                        f"{model_file} maps {model.input_unit} to {model.output_unit}")
    prediction = model.predict_run(run_of(data))
    measured = np.isfinite(data.outputs)
    err = prediction[measured] - data.outputs[measured]
    result = {"prediction_um": prediction, "rmse_um": rmse(err), "max_abs_um": max_abs(err),
              "n_points": int(prediction.size), "n_measured": int(measured.sum()),
              "input_unit": data.input_unit, "output_unit": data.output_unit}
    if as_json:
        print_json(result)
        return
    u = unit_token(data.output_unit)
    click.echo(f"{file}: {prediction.size} points predicted with {model_file}, {result['n_measured']} measured")
    click.echo(format_table([f"rmse_{u}", f"max_abs_{u}"], [[result["rmse_um"], result["max_abs_um"]]]))
