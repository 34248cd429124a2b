"""``reversible``: a reversible (anhysteretic) component -- a smooth single-valued function of the input.

Added to the Preisach output, it replaces and extends the thermal term
``c_d v`` of equation (22) (its first term: thermal expansion is not
exactly linear in the voltage; a magnetic sample's reversible
magnetisation is not linear in the field).  A cubic spline of the input
with knots on the grid's walls, value 0 at the lowest wall (the bias
``mu0`` holds the constant), constant beyond the ends::

    R(v) = sum_k d_k G_k(v),     G_k = sum_{j >= k} (B_j(v) - B_j(v_0))

``B_j`` the cubic B-splines on the walls and ``d_k`` the increments of
their coefficients, so that a roughness penalty on the increments'
differences (second differences of the coefficients) leaves a straight
line free, and -- option ``monotone`` (``--with reversible:monotone``) --
increments of one sign (chosen by the fit) make ``R`` rise or fall
throughout.  Cubic within each cell: on a run whose identification inputs
sit on the walls, what the density cannot absorb of a smooth ``R`` lives
inside the cells, where a piecewise-linear form has nothing to offer.

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
from .bases import second_differences

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


DEGREE = 3


def _knots(walls: np.ndarray) -> np.ndarray:
    w = np.asarray(walls, dtype=float)
    return np.concatenate([[w[0]] * DEGREE, w, [w[-1]] * DEGREE])


def increment_basis(walls: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(n, K - 1)``: ``G_k`` (see the module doc) at ``v`` (clamped to the walls), ``K`` cubic B-splines."""
    from scipy.interpolate import BSpline

    knots = _knots(walls)
    w = np.asarray(walls, dtype=float)
    x = np.clip(np.asarray(v, dtype=float), w[0], w[-1])
    b = BSpline.design_matrix(x, knots, DEGREE).toarray()
    b0 = BSpline.design_matrix(np.array([w[0]]), knots, DEGREE).toarray()
    b = b - b0
    return np.cumsum(b[:, ::-1], axis=1)[:, ::-1][:, 1:]


def greville(walls: np.ndarray) -> np.ndarray:
    """The Greville abscissae of the cubic B-splines on ``walls``."""
    t = _knots(walls)
    return np.array([t[j + 1:j + 1 + DEGREE].mean() for j in range(t.size - DEGREE - 1)])


class Reversible(Effect):
    name = "reversible"
    summary = "a reversible (anhysteretic) component: a smooth single-valued function of the input"
    stage = OUTPUT
    replaces_thermal_term = True
    options = ("monotone",)
    #: A cubic spline of the set-point between its walls.
    inversion = "static"
    static_degree = DEGREE

    def __init__(self, params: dict[str, Any] | None = None, *, monotone: bool = False) -> None:
        super().__init__(params)
        self.monotone = bool(monotone if params is None else self.params.get("monotone", False))

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("walls", "increments_um"), self.name)
        walls = finite_array(params, "walls", self.name)
        inc = finite_array(params, "increments_um", self.name)
        if walls.size < 2 or np.any(np.diff(walls) <= 0) or inc.size != walls.size + DEGREE - 2:
            raise IdentifyError(f"effect {self.name!r}: 'walls' must rise, with {walls.size + DEGREE - 2} increments")
        return {"walls": walls.tolist(), "increments_um": inc.tolist(), "monotone": bool(params.get("monotone", False))}

    def static_breakpoints_V(self) -> list[float]:
        """The spline's knots: its walls (V)."""
        return [float(k) for k in (self.params or {}).get("walls") or []]

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return needs_off_wall(runs, grid, self.name)

    def settings_grid(self) -> list[dict[str, float]]:
        signs = (1.0, -1.0) if self.monotone else (1.0,)
        return [{"sign": s, "smoothing": w} for s in signs for w in SMOOTHING]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        signs = (1.0, -1.0) if self.monotone else (1.0,)
        return [{"sign": s, "smoothing": FIT_SMOOTHING} for s in signs]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """``G_k`` at every point; the penalty is the squared differences of neighbouring increments over the
        Greville abscissae (second divided differences of the coefficients): a straight line is free."""
        walls = ctx.grid.walls
        sign = setting.get("sign", 1.0)
        values = [sign * increment_basis(walls, r.inputs) for r in ctx.runs]
        k = values[0].shape[1]
        labels = tuple(f"increment_{j}" for j in range(1, k + 1))
        g = greville(walls)
        # increments d_k = c_k - c_{k-1}: the coefficients' second differences are the increments' first
        # differences, weighed as second divided differences over the abscissae
        d2 = second_differences(g)                      # (K - 2, K) on the coefficients c
        to_c = np.tril(np.ones((k + 1, k)), -1)          # c = to_c @ d (c_0 = 0)
        rough = (d2 @ to_c).T @ (d2 @ to_c)
        return Columns(tuple(values), labels, (self.monotone,) * k, (-1,) * k, rough, setting.get("smoothing", 0.0))

    def with_fit(self, ctx, setting, coef, cols) -> "Reversible":
        inc = setting.get("sign", 1.0) * np.asarray(coef, dtype=float)
        return Reversible({"walls": ctx.grid.walls.tolist(), "increments_um": inc.tolist(), "monotone": self.monotone})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        p = self.params
        return increment_basis(np.asarray(p["walls"]), run.inputs) @ np.asarray(p["increments_um"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        w = np.asarray(self.params["walls"])
        v = np.linspace(w[0], w[-1], 8 * (w.size - 1) + 1)
        r = increment_basis(w, v) @ np.asarray(self.params["increments_um"])
        slope = np.diff(r) / np.diff(v)
        return {"monotone": self.params["monotone"], "range_um": float(np.ptp(r)),
                "mean_slope_um_per_V": float((r[-1] - r[0]) / (v[-1] - v[0])),
                "slope_range_um_per_V": [float(slope.min()), float(slope.max())],
                "values_at_walls_um": (increment_basis(w, w) @ np.asarray(self.params["increments_um"])).tolist()}
