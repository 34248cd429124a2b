"""Scoring a stored model on a recorded run, with the checks that make the score mean something."""

from __future__ import annotations

import numpy as np

from identify import IdentifyError
from identify.validation import ValidationReport, check_covers, validate_run
from sessions import ModelRecord
from sessions.recording import Recording

from .errors import UserError
from .session_input import run_of


def score_model(
    record: ModelRecord, data: Recording, *, fitted_on: bool = False, rows: np.ndarray | None = None
) -> ValidationReport:
    """Predict ``data`` with ``record``'s model and compare where measured (at ``rows``, default all).

    Every applied point is predicted, from negative saturation, so each
    compared point has the memory state of its full input history.  The
    run must have the model's units and its compared points must lie on
    the model's grid (unless ``fitted_on``: the run the model was
    identified from, whose inputs the fit saw, saturated or not); applied
    points that are not compared may go beyond it -- a FORC protocol's
    saturation field -- where the model saturates as the sample does.
    A model with effects acts on the whole run (time stamps, dwells); its
    drifts are re-estimated, held out, on a run they were not fitted on.
    Problems are one-line :class:`UserError`.
    """
    model = record.model
    if (model.input_unit, model.output_unit) != (data.input_unit, data.output_unit):
        raise UserError(
            f"{data.path}: records {data.input_unit} in and {data.output_unit} out, but model "
            f"{record.name!r} maps {model.input_unit} to {model.output_unit}"
        )
    try:
        run = run_of(data, rows=rows)
        if not fitted_on and run.rows.size:
            check_covers(model.grid, run.inputs[run.rows], model.input_unit)
        return validate_run(model, run, check_range=False)
    except IdentifyError as exc:
        raise UserError(f"{data.path}: model {record.name!r}: {exc}") from None
