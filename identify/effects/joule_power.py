"""``joule_power``: the thermal-expansion term follows heater power (``v^2``), not voltage.

A contribution ``c v^2`` (``c`` in um/V^2) on the set-points, beside
``c_d v``: expansion follows the beam's temperature rise, which Joule
heating makes quadratic in the heater voltage.  Like any function of the
input alone it is identifiable only from measured inputs off the grid's
walls (on the walls it is a combination of the diagonal cells' signed
areas, see :mod:`identify.effects.reversible`).
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

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("um_per_V2",), self.name)
        return {"um_per_V2": finite(params, "um_per_V2", self.name)}

    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        return needs_heater(runs)

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return self.applicable(runs) or needs_off_wall(runs, grid, self.name)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        return single_columns(ctx.runs, [(r.inputs ** 2)[:, None] for r in ctx.runs], ("um_per_V2",))

    def with_fit(self, ctx, setting, coef, cols) -> "JoulePower":
        return JoulePower({"um_per_V2": float(coef[0])})

    def contribution(self, run: Run) -> np.ndarray:
        return self.params["um_per_V2"] * run.inputs ** 2
