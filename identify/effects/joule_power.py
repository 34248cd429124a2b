"""``joule_power``: the thermal-expansion term follows heater power, not voltage.

Thermal expansion follows the beam's temperature rise, which Joule heating
makes ``~ v^2``; its coefficient may itself change with temperature, and a
rise may saturate.  A smooth function of the power ``P = v^2`` (V^2) on the
set-points, beside ``c_d v``: ``a P + b P^2`` (``a`` in um/V^2, ``b`` in
um/V^4) -- a power law of the rise between about 0.6 and 2, or a
saturating one, over the heater's range.  It is the ``reversible``
component's special case for heater physics, with two coefficients where
the general one has one per wall: when both explain a gap as well, the
diagnosis names this one.  Like any function of the input alone it is
identifiable only from measured inputs off the grid's walls.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite, needs_heater, require_params, single_columns
from .reversible import needs_off_wall


class JoulePower(Effect):
    name = "joule_power"
    summary = "the thermal-expansion term follows heater power (v^2), not voltage"
    stage = OUTPUT
    #: A special case of this effect (the diagnosis prefers it when both explain as well).
    within = "reversible"
    must_record = (needs_heater,)
    #: ``a v^2 + b v^4`` of the set-point.
    inversion = "static"
    static_degree = 4

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("um_per_V2",), self.name)
        return {"um_per_V2": finite(params, "um_per_V2", self.name),
                "um_per_V4": finite(params, "um_per_V4", self.name) if "um_per_V4" in params else 0.0}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return self.applicable(runs) or needs_off_wall(runs, grid, self.name)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        return single_columns(ctx.runs, [np.stack([r.inputs ** 2, r.inputs ** 4], axis=1) for r in ctx.runs],
                              ("um_per_V2", "um_per_V4"))

    def with_fit(self, ctx, setting, coef, cols) -> "JoulePower":
        return JoulePower({"um_per_V2": float(coef[0]), "um_per_V4": float(coef[1])})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        p = run.inputs ** 2
        return self.params["um_per_V2"] * p + self.params["um_per_V4"] * p * p
