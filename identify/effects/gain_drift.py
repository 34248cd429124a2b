"""``gain_drift``: the sensor's sensitivity wanders over session time (laser power, alignment, the
temperature of the optical lever).

The reading is the deflection, measured from the sensor's zero, times a
slowly varying factor: ``y = u (1 + g(t))``, ``g`` a smooth function of
session time per run -- a penalised cubic spline with knots every
:data:`~identify.effects.bases.KNOT_S` seconds, like the additive drifts.
Linear in the spline's coefficients at a given output, so its columns are
the model's output times each spline.  The first run's ``g`` has zero mean
over its measured points: a constant gain is a rescaling of the whole model
(density, bias and thermal term), which the fit makes anyway.  A per-run
nuisance: a stored model knows the gain drift of the runs it was fitted on,
by name, and nothing of another run's (a validation re-estimates it held
out, :mod:`identify.effects.nuisance`).

Where it differs from ``baseline_drift``: an offset moves every reading by
the same amount at a given time; a gain moves large deflections more than
small ones, and not at all at the sensor's zero.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..runs import Run
from .ambient_drift import FIT_SMOOTHING, drift_report, drift_settings
from .base import OUTPUT, Columns, Context, Effect, needs_time
from .bases import KNOT_S, centred_first, drift_bases, per_run_columns, run_splines, spline_of


class GainDrift(Effect):
    name = "gain_drift"
    summary = "the sensor's sensitivity drifts over session time (laser power, alignment)"
    stage = OUTPUT
    per_run = True
    must_record = (needs_time,)
    #: On a run it was not fitted on it is unknown and changes nothing.
    inversion = "inert"
    needs_output = True
    from_base = True

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        if not isinstance(params.get("runs"), dict):
            raise IdentifyError(f"effect {self.name!r} needs 'runs': {{run name: spline}}")
        return {"runs": params["runs"]}

    def settings_grid(self) -> list[dict[str, float]]:
        return drift_settings()

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"smoothing": FIT_SMOOTHING}]

    def _columns(self, ctx: Context, setting: dict[str, float], centre_first: bool) -> Columns:
        # the first run's mean gain is the model's scale: its drift has zero mean
        knot = setting.get("knot_s", KNOT_S)
        bases = drift_bases(ctx.runs, knot, centre_first)
        blocks = [ctx.bare_output(i)[:, None] * b for i, b in enumerate(bases)]
        return per_run_columns(ctx.runs, blocks, "gain", setting.get("smoothing", 0.0), knot)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """Each run's output times its splines; the first run's splines centred on its measured points."""
        return self._columns(ctx, setting, centre_first=True)

    def nuisance_columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """On another run the gain has its own constant too (each run its own sensitivity)."""
        return self._columns(ctx, setting, centre_first=False)

    def with_fit(self, ctx, setting, coef, cols) -> "GainDrift":
        knot = setting.get("knot_s", KNOT_S)
        coef = centred_first(ctx.runs, cols, coef, knot)  # the first run's columns were centred: so is its drift
        previous = (self.params or {}).get("runs", {})
        return GainDrift({"runs": {**previous, **run_splines(ctx.runs, cols, coef, knot_s=knot)}})

    def gain(self, run: Run) -> np.ndarray:
        """``g(t)`` at every point of ``run`` ``(n,)`` (relative: 0.01 is one per cent); zero on a run the
        model does not know."""
        entry = self.params["runs"].get(run.name)
        return np.zeros(run.n) if entry is None else spline_of(entry, run.t_s)

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        if u is None:
            raise IdentifyError("gain_drift needs the model's output to act on")
        return np.asarray(u, dtype=float) * self.gain(run)

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return drift_report(self.params, "gain", runs)
