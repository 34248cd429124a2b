"""``baseline_drift``: the sensor zero wanders over session time (laser pointing, mechanics).

A smooth function of session time per run (um): a penalised cubic spline
with knots every :data:`~identify.effects.bases.KNOT_S` seconds (in the
diagnosis, every 600 or 200 s: a setting).  The
first run's drift has zero mean over its measured points (its constant is
the bias's).  A
per-run nuisance: a stored model knows the drift of the runs it was fitted
on, by name, and nothing of another run's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..runs import Run
from .ambient_drift import FIT_SMOOTHING, drift_report, drift_settings
from .base import OUTPUT, Columns, Context, Effect, needs_time
from .bases import KNOT_S, centred_first, drift_bases, per_run_columns, run_splines, spline_of


class BaselineDrift(Effect):
    name = "baseline_drift"
    summary = "the sensor zero drifts over session time (laser pointing, mechanics)"
    look_alikes = ("the loop changing slowly with use (training or fatigue of the film)",)
    stage = OUTPUT
    per_run = True
    must_record = (needs_time,)
    #: On a run it was not fitted on it is unknown and changes nothing.
    inversion = "inert"

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        if not isinstance(params.get("runs"), dict):
            raise IdentifyError(f"effect {self.name!r} needs 'runs': {{run name: spline}}")
        return {"runs": params["runs"]}

    def settings_grid(self) -> list[dict[str, float]]:
        return drift_settings()

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"smoothing": FIT_SMOOTHING}]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """Each run's splines; the first run's centred on its measured points (its constant is the bias
        ``mu0``'s, which the model fits anyway)."""
        knot = setting.get("knot_s", KNOT_S)
        return per_run_columns(ctx.runs, drift_bases(ctx.runs, knot), "spline", setting.get("smoothing", 0.0), knot)

    def nuisance_columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """On another run the drift has its own constant too (each run its own sensor zero)."""
        knot = setting.get("knot_s", KNOT_S)
        return per_run_columns(ctx.runs, drift_bases(ctx.runs, knot, centre_first=False), "spline",
                               setting.get("smoothing", 0.0), knot)

    def with_fit(self, ctx, setting, coef, cols) -> "BaselineDrift":
        previous = (self.params or {}).get("runs", {})
        knot = setting.get("knot_s", KNOT_S)
        # the columns were centred on the first run: so is its spline (its functions add up to one)
        coef = centred_first(ctx.runs, cols, coef, knot)
        return BaselineDrift({"runs": {**previous, **run_splines(ctx.runs, cols, coef, knot_s=knot)}})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        entry = self.params["runs"].get(run.name)
        return np.zeros(run.n) if entry is None else spline_of(entry, run.t_s)

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return drift_report(self.params, "um", runs)
