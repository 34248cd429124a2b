"""``sensor_nonlinearity``: the sensor reading is a mildly nonlinear, saturating function of the deflection.

The reading is ``y = u + a z^2 + b z^3`` with ``z = (u - centre) / half_range``
the deflection scaled to [-1, 1] over the identification outputs (``a``,
``b``, ``centre``, ``half_range`` in um).  Linear in ``a``, ``b`` at a given
``u``; the joint fit takes Gauss--Newton steps, whose derivative with
respect to the model's other parameters is the map's slope
(:meth:`SensorNonlinearity.slope`) times theirs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .base import SENSOR, Columns, Context, Effect, finite, require_params, single_columns

KEYS = ("quadratic_um", "cubic_um", "centre_um", "half_range_um")


class SensorNonlinearity(Effect):
    name = "sensor_nonlinearity"
    summary = "the sensor reading is a mildly nonlinear, saturating function of the deflection"
    stage = SENSOR

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, KEYS, self.name)
        out = {k: finite(params, k, self.name) for k in KEYS}
        if out["half_range_um"] <= 0:
            from ..errors import IdentifyError

            raise IdentifyError(f"effect {self.name!r}: half_range_um must be > 0")
        return out

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        c, h = (self.params["centre_um"], self.params["half_range_um"]) if self.fitted else (
            ctx.output_centre, ctx.output_half_range)
        values = []
        for u in ctx.predictions:
            z = (u - c) / h
            values.append(np.stack([z ** 2, z ** 3], axis=1))
        return single_columns(ctx.runs, values, ("quadratic_um", "cubic_um"))

    def with_fit(self, ctx, setting, coef, cols) -> "SensorNonlinearity":
        c, h = (self.params["centre_um"], self.params["half_range_um"]) if self.fitted else (
            ctx.output_centre, ctx.output_half_range)
        return SensorNonlinearity({"quadratic_um": float(coef[0]), "cubic_um": float(coef[1]),
                                   "centre_um": c, "half_range_um": h})

    def slope(self, u: np.ndarray) -> np.ndarray:
        p = self.params
        z = (u - p["centre_um"]) / p["half_range_um"]
        return 1.0 + (2.0 * p["quadratic_um"] * z + 3.0 * p["cubic_um"] * z ** 2) / p["half_range_um"]

    def sense(self, u: np.ndarray) -> np.ndarray:
        p = self.params
        z = (u - p["centre_um"]) / p["half_range_um"]
        return u + p["quadratic_um"] * z ** 2 + p["cubic_um"] * z ** 3
