"""``interaction``: mean-field interaction between hysterons (the "moving" Preisach model).

The hysterons see the input plus a multiple of the output, ``x = v + k u``
(``k`` in input units per output unit).  On the VO2 actuator the
transition temperature moves with stress, which the deflection itself
changes; in a magnetic sample the field each grain feels includes the
sample's magnetisation.  ``k > 0`` steepens and widens the loop, ``k < 0``
shears it.

* **Fitting** takes the output the hysterons feel from the run itself --
  the measured output where measured, the model's prediction elsewhere
  (:attr:`identify.effects.base.Context.feedback`) -- so for a given ``k``
  the regressor is exact and ``k`` is found by Gauss--Newton steps.
* **Prediction** has no measurement to lean on: the output depends on the
  memory state, which depends on the output.  Each step solves the fixed
  point exactly along the memory curve (:mod:`identify.effects.compose`).

Not identifiable from a run whose input never turns back.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..grid import Grid
from ..runs import Run
from .base import INPUT, Columns, Context, Effect, finite, needs_reversals, require_params, single_columns

#: Step of the secant in ``k``, relative to the input range over the output range.
STEP = 1e-3
#: Where the joint fit starts ``k`` (relative to the input range over the output range): the
#: measured-feedback residual can have local minima when the feedback is strong.
STARTS = (-0.5, -0.2, 0.0, 0.2, 0.5)


class Interaction(Effect):
    name = "interaction"
    summary = "mean-field interaction: the hysterons feel the output as well as the input (x = v + k u)"
    stage = INPUT

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("k",), self.name)
        return {"k": finite(params, "k", self.name)}

    @property
    def k(self) -> float:
        return self.params["k"] if self.fitted else 0.0

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return needs_reversals(runs, "mean-field feedback shows only where the input turns back")

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"start": s} for s in STARTS]

    def with_setting(self, setting: dict[str, float], ctx: Context | None = None) -> "Interaction":
        if self.fitted or ctx is None or not setting.get("start"):
            return self
        scale = (ctx.grid.v_max - ctx.grid.v_min) / (2.0 * ctx.output_half_range)
        return Interaction({"k": float(setting["start"]) * scale})

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        if not self.k:
            return x
        if feedback is None:
            raise ValueError("interaction needs the output the hysterons feel (prediction solves a fixed point)")
        return x + self.k * feedback

    def step(self, ctx: Context) -> float:
        """The secant step in ``k``: :data:`STEP` times the input range per output range."""
        return STEP * (ctx.grid.v_max - ctx.grid.v_min) / (2.0 * ctx.output_half_range)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        dk = self.step(ctx)
        values = []
        for i, run in enumerate(ctx.runs):
            x = ctx.inputs[i]
            values.append(((ctx.response(i, x + dk * ctx.feedback[i]) - ctx.response(i, x)) / dk)[:, None])
        return single_columns(ctx.runs, values, ("k",))

    def with_fit(self, ctx, setting, coef, cols) -> "Interaction":
        return Interaction({"k": float(self.k + coef[0])})
