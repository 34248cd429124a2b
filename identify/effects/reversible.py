"""``reversible``: a reversible (anhysteretic) component -- a smooth single-valued function of the input.

Added to the Preisach output, it replaces and extends the thermal term
``c_d v`` of equation (22) (its first term: thermal expansion is not
exactly linear in the voltage; a magnetic sample's reversible
magnetisation is not linear in the field).  Piecewise linear on knots --
the grid's walls -- with value 0 at the lowest (the bias ``mu0`` holds the
constant), constant beyond the ends::

    R(v) = sum_k d_k ramp_k(v)          (ramps of :func:`identify.effects.bases.ramps`)

Option ``monotone`` (``--with reversible:monotone``): the increments ``d_k``
share one sign (chosen by the fit), so ``R`` rises or falls throughout.

**Identifiability.**  On the walls, diagonal cell ``(i, i)`` is +1 exactly
when the input is above it, so any function of the input, sampled on the
walls, is a combination of the diagonal cells' signed areas: only measured
inputs *off* the walls tell a reversible component from the hysteresis.  A
run without one is refused.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite_array, require_params
from .bases import ramps

OPTIONS = ("monotone",)
#: Weights of the roughness penalty (second differences of the values at the knots) the diagnosis tries.
SMOOTHING = (0.01, 0.1, 1.0, 10.0)
#: The weight when a model is fitted with it (``rig identify --with``): a light touch.
FIT_SMOOTHING = 0.01


def needs_off_wall(runs: tuple[Run, ...], grid: Grid, name: str) -> str | None:
    """Why a function of the input alone cannot be identified from these runs (None: it can)."""
    for r in runs:
        v = r.inputs[r.rows]
        inside = (v > grid.v_min) & (v < grid.v_max)
        if np.any(inside & ~grid.on_walls(v)):
            return None
    return ("every measured input sits on a wall of the grid (or beyond it), where a function of the input is "
            "a combination of the diagonal cells' signed areas; measure points off the walls (a random input, "
            "the damped oscillation's thermal point, a run on another grid)")


class Reversible(Effect):
    name = "reversible"
    summary = "a reversible (anhysteretic) component: a smooth single-valued function of the input"
    stage = OUTPUT
    replaces_thermal_term = True

    def __init__(self, params: dict[str, Any] | None = None, *, monotone: bool = False) -> None:
        super().__init__(params)
        self.monotone = bool(monotone if params is None else self.params.get("monotone", False))

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("knots", "values_um"), self.name)
        knots = finite_array(params, "knots", self.name)
        values = finite_array(params, "values_um", self.name)
        if knots.size < 2 or values.size != knots.size or np.any(np.diff(knots) <= 0):
            raise IdentifyError(f"effect {self.name!r}: 'knots' must rise and match 'values_um' in length (>= 2)")
        return {"knots": [float(x) for x in knots], "values_um": [float(x) for x in values],
                "monotone": bool(params.get("monotone", False))}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return needs_off_wall(runs, grid, self.name)

    def settings_grid(self) -> list[dict[str, float]]:
        signs = (1.0, -1.0) if self.monotone else (1.0,)
        return [{"sign": s, "smoothing": w} for s in signs for w in SMOOTHING]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        signs = (1.0, -1.0) if self.monotone else (1.0,)
        return [{"sign": s, "smoothing": FIT_SMOOTHING} for s in signs]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """Ramps between the walls (coefficients: the increments between knots); the penalty is the squared
        differences of neighbouring increments (second differences of the values), so a straight line is
        free."""
        knots = ctx.grid.walls
        sign = setting.get("sign", 1.0)
        labels = tuple(f"step_{k}" for k in range(1, knots.size))
        values = [sign * ramps(knots, r.inputs) for r in ctx.runs]
        k = len(labels)
        d = np.diff(np.eye(k), n=1, axis=0)
        return Columns(tuple(values), labels, (self.monotone,) * k, (-1,) * k, d.T @ d if k > 1 else None,
                       setting.get("smoothing", 0.0))

    def with_fit(self, ctx, setting, coef, cols) -> "Reversible":
        knots = ctx.grid.walls
        steps = setting.get("sign", 1.0) * np.asarray(coef, dtype=float)
        values = np.concatenate([[0.0], np.cumsum(steps)])
        return Reversible({"knots": knots.tolist(), "values_um": values.tolist(), "monotone": self.monotone})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None) -> np.ndarray:
        p = self.params
        return np.interp(run.inputs, p["knots"], p["values_um"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        v = np.asarray(self.params["values_um"])
        k = np.asarray(self.params["knots"])
        slope = np.diff(v) / np.diff(k)
        return {**self.params, "range_um": float(np.ptp(v)), "mean_slope_um_per_V": float((v[-1] - v[0]) / (k[-1] - k[0])),
                "slope_range_um_per_V": [float(slope.min()), float(slope.max())]}
