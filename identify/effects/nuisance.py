"""A stored model's per-run effects on a run it was not fitted on: re-estimated, held out.

A drift (``baseline_drift``, ``ambient_drift``) belongs to the run it was
fitted on; a model knows nothing of another run's.  To validate such a
model honestly on another run, that run's own drift is estimated from the
run itself without letting any point judge itself: the run's measured
points are cut into contiguous blocks (:func:`identify.cross_validation.make_blocks`),
and each block is predicted with a drift fitted on all the other blocks
(:func:`identify.cross_validation.cross_validate`, the penalty weight
chosen by an inner cross-validation) -- exactly how the gap diagnosis
scores a drift candidate.  Nothing else of the model is refitted.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..cross_validation import Design, cross_validate, make_blocks
from ..model import PreisachModel
from ..runs import Run
from .base import Effect
from .joint import context_of


def unknown_nuisance(model: PreisachModel, run: Run) -> list[Effect]:
    """The model's per-run effects that do not know ``run`` (fitted on other runs)."""
    return [e for e in model.effects if not e.knows_run(run.name)]


def held_out_prediction(model: PreisachModel, run: Run) -> tuple[np.ndarray, dict[str, Any]]:
    """The model's reading at every point of ``run`` ``(n,)``, with its per-run effects that do not
    know the run re-estimated held out on the run's measured points; and what was done, by effect.

    Without such effects this is :meth:`PreisachModel.predict_run`.
    """
    unknown = unknown_nuisance(model, run)
    prediction = model.predict_run(run)
    if not unknown:
        return prediction, {}
    rows = run.rows
    known = tuple(e for e in model.effects if e not in unknown)
    ctx = context_of(replace(model, effects=known), [run], known)
    blocks = make_blocks([rows.size])
    gap = run.outputs[rows] - prediction[rows]
    done: dict[str, Any] = {}
    for e in unknown:
        fresh = e.for_another_run()
        settings = fresh.settings_grid()
        designs = []
        for s in settings:
            cols = fresh.nuisance_columns(ctx, s)
            designs.append(Design(cols.values[0][rows], None, cols.roughness, cols.smoothing))
        cv = cross_validate(gap, blocks, designs)
        gap = gap - cv.prediction
        prediction = prediction.copy()
        prediction[rows] += cv.prediction
        done[e.name] = {"re_estimated": "held out", "blocks": int(blocks.count),
                        "setting": settings[cv.full_setting]}
    return prediction, done
