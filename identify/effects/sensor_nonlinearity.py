"""``sensor_nonlinearity``: the sensor reading is a smooth nonlinear function of the deflection.

The reading is ``y = u + c(z)``, ``z = (u - centre) / half_range`` the
deflection scaled to [-1, 1] over the identification outputs, and ``c`` a
natural cubic spline of ``z`` (um) on :data:`KNOTS_Z`: any smooth shape
inside the range (a saturating detector, an off-centre spot, an asymmetric
response), linear beyond its end knots (so the map is never extrapolated as
a cubic).  Its constant and linear parts are left out: an offset and a gain
of the reading are the bias's and the density's (the model's scale).
``c`` is linear in its coefficients at a given ``u``; the joint fit takes
Gauss--Newton steps whose derivative with respect to the model's other
parameters is the map's slope (:meth:`SensorNonlinearity.slope`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from .base import SENSOR, Columns, Context, Effect, finite, finite_array, require_params, single_columns

#: Knots of the correction's natural cubic spline, on the scaled deflection.
KNOTS_Z = (-1.0, -0.5, 0.0, 0.5, 1.0)
#: Step of the numerical slope, on the scaled deflection.
SLOPE_STEP = 1e-6


def natural_basis(z: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """The natural cubic spline basis without its constant and linear functions: ``(n, K - 2)``
    (Hastie, Tibshirani and Friedman, eq. 5.4-5.5): cubic between the knots, linear beyond the ends."""
    z = np.asarray(z, dtype=float)[:, None]
    t = np.asarray(knots, dtype=float)

    def d(k: int) -> np.ndarray:
        return (np.maximum(z - t[k], 0.0) ** 3 - np.maximum(z - t[-1], 0.0) ** 3) / (t[-1] - t[k])

    last = d(t.size - 2)
    return np.hstack([d(k) - last for k in range(t.size - 2)])


class SensorNonlinearity(Effect):
    name = "sensor_nonlinearity"
    summary = "the sensor reading is a smooth nonlinear (e.g. saturating) function of the deflection"
    look_alikes = ("any static map of the deflection on its way to the reading (reflections on the PSD, the "
                   "spot's size, a saturating amplifier)",)
    stage = SENSOR
    inversion = "sensor"

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("knots_z", "coefficients_um", "centre_um", "half_range_um"), self.name)
        knots = finite_array(params, "knots_z", self.name)
        coef = finite_array(params, "coefficients_um", self.name)
        half = finite(params, "half_range_um", self.name)
        if knots.size < 3 or np.any(np.diff(knots) <= 0) or coef.size != knots.size - 2 or half <= 0:
            raise IdentifyError(f"effect {self.name!r}: needs rising knots_z (>= 3), one coefficient per knot "
                                "but two, and half_range_um > 0")
        return {"knots_z": knots.tolist(), "coefficients_um": coef.tolist(),
                "centre_um": finite(params, "centre_um", self.name), "half_range_um": half}

    def _scale(self, ctx: Context) -> tuple[float, float]:
        if self.fitted:
            return self.params["centre_um"], self.params["half_range_um"]
        return ctx.output_centre, ctx.output_half_range

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        c, h = self._scale(ctx)
        knots = np.asarray(KNOTS_Z)
        labels = tuple(f"spline_{k}_um" for k in range(knots.size - 2))
        return single_columns(ctx.runs, [natural_basis((u - c) / h, knots) for u in ctx.predictions], labels)

    def with_fit(self, ctx, setting, coef, cols) -> "SensorNonlinearity":
        c, h = self._scale(ctx)
        return SensorNonlinearity({"knots_z": list(KNOTS_Z), "coefficients_um": np.asarray(coef, float).tolist(),
                                   "centre_um": c, "half_range_um": h})

    def correction(self, u: np.ndarray) -> np.ndarray:
        p = self.params
        z = (np.asarray(u, dtype=float) - p["centre_um"]) / p["half_range_um"]
        return natural_basis(z.ravel(), np.asarray(p["knots_z"])).reshape(z.shape + (-1,)) @ np.asarray(
            p["coefficients_um"])

    def sense(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(u, dtype=float) + self.correction(u)

    def slope(self, u: np.ndarray) -> np.ndarray:
        du = SLOPE_STEP * self.params["half_range_um"]
        return 1.0 + (self.correction(np.asarray(u) + du) - self.correction(np.asarray(u) - du)) / (2.0 * du)

    def report(self, runs=()) -> dict[str, Any]:
        p = self.params
        z = np.linspace(-1.0, 1.0, 41)
        corr = self.correction(p["centre_um"] + p["half_range_um"] * z)
        return {**p, "correction_range_um": float(np.ptp(corr)), "correction_at_ends_um": [float(corr[0]), float(corr[-1])]}
