"""``first_point``: the first reading after a reversal differs systematically.

At a reversal the input turns back; the readings right there are taken
after a change of direction that the rest of a branch does not see (the
FORC "first-point artefact" at each curve's reversal field; on the VO2 rig,
the first dwell after the heater turns back).  Two places, each with an
offset that may depend on the direction and on the size of the excursion
``E`` (signed, in input units) that ended at the reversal::

    at the reversal point:        a0 + a1 sign(E) + a2 E
    at the first point after it:  b0 + b1 sign(E) + b2 E

(um).  Derived from the input history alone (:class:`identify.runs.History`),
so any run with reversals carries it; a run whose input never turns back
cannot identify it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite_array, needs_reversals, single_columns

LABELS = ("at_offset_um", "at_direction_um", "at_um_per_V", "after_offset_um", "after_direction_um",
          "after_um_per_V")


def indicators(run: Run) -> np.ndarray:
    """``(n, 6)``: the terms above at every point (zero away from reversals)."""
    h = run.history
    out = np.zeros((run.n, 6))
    e = h.excursion_V
    terms = np.stack([np.ones_like(e), np.sign(e), e], axis=1)
    out[h.reversal_index, :3] += terms
    out[h.turn_index, 3:] += terms
    return out


class FirstPoint(Effect):
    name = "first_point"
    summary = "the first reading after a reversal differs systematically (a first-point artefact)"
    stage = OUTPUT

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        return {"coefficients_um": finite_array(params, "coefficients_um", self.name).tolist(), "terms": list(LABELS)}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        why = needs_reversals(runs, "it acts where the input turns back")
        if why is not None:
            return why
        if not any(np.any(np.isfinite(r.outputs[r.history.reversal_index])) or
                   np.any(np.isfinite(r.outputs[r.history.turn_index])) for r in runs):
            return "no reading was taken at a reversal or right after one"
        return None

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        return single_columns(ctx.runs, [indicators(r) for r in ctx.runs], LABELS)

    def with_fit(self, ctx, setting, coef, cols) -> "FirstPoint":
        return FirstPoint({"coefficients_um": np.asarray(coef, dtype=float).tolist()})

    def contribution(self, run: Run) -> np.ndarray:
        return indicators(run) @ np.asarray(self.params["coefficients_um"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return dict(zip(LABELS, self.params["coefficients_um"]))
