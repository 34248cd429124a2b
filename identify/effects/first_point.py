"""``first_point``: the first reading after a reversal differs systematically.

At a reversal the input turns back; the readings right there are taken
after a change of direction that the rest of a branch does not see (the
FORC "first-point artefact" at each curve's reversal field; on the VO2 rig,
the first dwell after the heater turns back).  Two places, each with an
offset (um) that may depend on the direction and on the size of a step:

* at the reversal point: ``a0 + a1 sign(E) + a2 E``, ``E`` the excursion
  (input units, signed) that ended there;
* at the first point after it: ``b0 + b1 d + b2 s``, ``s`` the reversing
  step (signed, input units) and ``d`` its direction -- optionally
  persisting over the next points, decaying geometrically by a ratio
  ``decay`` per point (a setting: 0, or 1/2).

Derived from the input history alone (:class:`identify.runs.History`), not
from time, so any run with reversals carries it; a run whose input never
turns back cannot identify it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite, finite_array, needs_reversals, single_columns

LABELS = ("at_offset_um", "at_direction_um", "at_um_per_V", "after_offset_um", "after_direction_um",
          "after_um_per_V")
#: Decay ratios of the after-reversal offset over the following points (a setting).
DECAYS = (0.0, 0.5)
#: Points after the first over which a persisting offset is followed.
PERSIST = 4


def indicators(run: Run, decay: float = 0.0) -> np.ndarray:
    """``(n, 6)``: the terms above at every point (zero away from reversals)."""
    h = run.history
    out = np.zeros((run.n, 6))
    e = h.excursion_V
    out_at = np.stack([np.ones_like(e), np.sign(e), e], axis=1)
    np.add.at(out, (h.reversal_index[:, None], np.arange(3)[None, :]), out_at)
    step = run.inputs[h.turn_index] - run.inputs[h.reversal_index]
    after = np.stack([np.ones_like(step), np.sign(step), step], axis=1)
    for j in range(PERSIST + 1 if decay else 1):
        idx = h.turn_index + j
        ok = idx < run.n
        np.add.at(out, (idx[ok][:, None], 3 + np.arange(3)[None, :]), (decay ** j) * after[ok])
    return out


class FirstPoint(Effect):
    name = "first_point"
    summary = "the first reading after a reversal differs systematically (a first-point artefact)"
    stage = OUTPUT

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        decay = finite(params, "decay", self.name) if "decay" in params else 0.0
        return {"coefficients_um": finite_array(params, "coefficients_um", self.name).tolist(), "terms": list(LABELS),
                "decay": decay}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        why = needs_reversals(runs, "it acts where the input turns back")
        if why is not None:
            return why
        if not any(np.any(np.isfinite(r.outputs[r.history.reversal_index])) or
                   np.any(np.isfinite(r.outputs[r.history.turn_index])) for r in runs):
            return "no reading was taken at a reversal or right after one"
        return None

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"decay": d} for d in DECAYS]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        decay = setting.get("decay", 0.0)
        return single_columns(ctx.runs, [indicators(r, decay) for r in ctx.runs], LABELS)

    def with_fit(self, ctx, setting, coef, cols) -> "FirstPoint":
        return FirstPoint({"coefficients_um": np.asarray(coef, dtype=float).tolist(), "decay": setting.get("decay", 0.0)})

    def contribution(self, run: Run, u: np.ndarray | None = None) -> np.ndarray:
        return indicators(run, self.params["decay"]) @ np.asarray(self.params["coefficients_um"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return {**dict(zip(LABELS, self.params["coefficients_um"])), "decay": self.params["decay"]}
