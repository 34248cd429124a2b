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

**The sensor's zero** (the *pivot*, um, in the reading's units) is where
the spot sits on the PSD's centre, and it need not be the reading's zero:
a logger that subtracts an offset, or a lever aligned so the spot crosses
the centre mid-swing, puts it anywhere.  So ``y = u + (u - p) g(t)``, and
the pivot ``p`` is a setting like the drift's knots: the reading's zero
(no ``pivot`` key, the default), or ``lo + f (hi - lo)`` for each ``f`` of
:data:`PIVOTS`, ``lo``/``hi`` the range of the model's output over the runs
fitted.  The fit (or the diagnosis's cross-validation) chooses it; a fitted
effect stores it as ``pivot_um`` and keeps it on another run of the same
sensor (:meth:`GainDrift.for_another_run`).  With the pivot fixed the terms
are linear; over the pivots they are the gain and offset drifts of one time
course, not two free drifts (which would be a baseline drift as well).

Where it differs from ``baseline_drift``: an offset moves every reading by
the same amount at a given time; a gain moves readings far from the
sensor's zero more than near ones, and not at all at the zero.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..runs import Run
from .ambient_drift import FIT_SMOOTHING, drift_report, drift_settings
from .base import OUTPUT, Columns, Context, Effect, needs_time
from .bases import KNOT_S, centred_first, drift_bases, per_run_columns, run_splines, spline_of

#: Where the sensor's zero may sit, as fractions of the range of the model's output over the runs (beside the
#: reading's zero): the spot crosses the PSD's centre somewhere on the loop (an operator centres it).  Zeros
#: outside the loop were tried (-0.25 and 1.25) and taken back: a gain about a far zero is an offset drift
#: with a little gain, and it took baseline drifts' names (see docs/results/2026-11-29-gain-pivot-and-slow-lag.md).
PIVOTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def output_range(ctx: Context) -> tuple[float, float]:
    """``(lo, hi)`` of the model's output before output effects over every run of ``ctx`` (um)."""
    both = np.concatenate([np.asarray(ctx.bare_output(i), dtype=float) for i in range(len(ctx.runs))] or [[]])
    both = both[np.isfinite(both)]
    return (float(both.min()), float(both.max())) if both.size else (0.0, 0.0)


class GainDrift(Effect):
    name = "gain_drift"
    summary = "the sensor's sensitivity drifts over session time (laser power, alignment)"
    look_alikes = ("the loop's size changing slowly with use (training or fatigue of the film)",)
    stage = OUTPUT
    per_run = True
    must_record = (needs_time,)
    #: On a run it was not fitted on it is unknown and changes nothing.
    inversion = "inert"
    needs_output = True
    from_base = True

    def __init__(self, params: dict[str, Any] | None = None, fixed_pivot_um: float | None = None) -> None:
        super().__init__(params)
        #: The sensor's zero when it is known already (another run of a fitted model's sensor), um; None:
        #: a setting chooses it.
        self.fixed_pivot_um = fixed_pivot_um

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        if not isinstance(params.get("runs"), dict):
            raise IdentifyError(f"effect {self.name!r} needs 'runs': {{run name: spline}}")
        pivot = params.get("pivot_um", 0.0)
        if not isinstance(pivot, (int, float)) or not np.isfinite(pivot):
            raise IdentifyError(f"effect {self.name!r}: 'pivot_um' must be a finite number (um)")
        return {"runs": params["runs"], "pivot_um": float(pivot)}

    @property
    def pivot_known(self) -> bool:
        """Whether the sensor's zero is fixed already (a fitted model's, on another run of its sensor)."""
        return self.fixed_pivot_um is not None

    def _pivots(self, settings: list[dict[str, float]]) -> list[dict[str, float]]:
        if self.pivot_known:
            return settings
        return settings + [{**s, "pivot": f} for f in PIVOTS for s in settings]

    def settings_grid(self) -> list[dict[str, float]]:
        """The drift's settings at every pivot (the reading's zero first; see the module doc)."""
        return self._pivots(drift_settings())

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return self._pivots([{"smoothing": FIT_SMOOTHING}])

    def for_another_run(self) -> "GainDrift":
        """The same sensor on another run: its zero is kept, its drift is that run's own."""
        return GainDrift(fixed_pivot_um=self.pivot_um if self.fitted else None)

    @property
    def pivot_um(self) -> float:
        """The sensor's zero in the reading's units (um): the fitted one (0 until fitted), or the fixed one."""
        if self.params is None and self.pivot_known:
            return self.fixed_pivot_um
        return float((self.params or {}).get("pivot_um", 0.0))

    def pivot_at(self, ctx: Context, setting: dict[str, float]) -> float:
        """The pivot ``setting`` stands for on ``ctx`` (um): the fixed one, the reading's zero (no ``pivot``
        key), or a fraction of the output's range."""
        if self.pivot_known:
            return self.fixed_pivot_um
        if "pivot" not in setting:
            return 0.0
        lo, hi = output_range(ctx)
        return lo + float(setting["pivot"]) * (hi - lo)

    def _columns(self, ctx: Context, setting: dict[str, float], centre_first: bool) -> Columns:
        # the first run's mean gain is the model's scale (about the pivot: a scale and an offset): its drift
        # has zero mean
        knot = setting.get("knot_s", KNOT_S)
        pivot = self.pivot_at(ctx, setting)
        bases = drift_bases(ctx.runs, knot, centre_first)
        blocks = [(ctx.bare_output(i) - pivot)[:, None] * b for i, b in enumerate(bases)]
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
        return GainDrift({"runs": {**previous, **run_splines(ctx.runs, cols, coef, knot_s=knot)},
                          "pivot_um": self.pivot_at(ctx, setting)}, self.fixed_pivot_um)

    def gain(self, run: Run) -> np.ndarray:
        """``g(t)`` at every point of ``run`` ``(n,)`` (relative: 0.01 is one per cent); zero on a run the
        model does not know."""
        entry = self.params["runs"].get(run.name)
        return np.zeros(run.n) if entry is None else spline_of(entry, run.t_s)

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        if u is None:
            raise IdentifyError("gain_drift needs the model's output to act on")
        return (np.asarray(u, dtype=float) - self.pivot_um) * self.gain(run)

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        """Each run's gain drift (:func:`drift_report`) and the sensor's zero, ``pivot_um``."""
        return {**drift_report(self.params, "gain", runs), "pivot_um": self.pivot_um}
