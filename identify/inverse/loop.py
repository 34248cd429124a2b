"""The model's major loop: its output range, and the linear inverse practitioners start from.

The **major loop** is the output for a sweep of the set-point from the low
end of the window to the high end and back, from negative saturation, at
rest (time-dependent effects -- creep, drifts -- left out; a thermal lag
settled).  With a non-negative density every output any input history can
give at a voltage lies between the loop's two branches there, so the
loop's extremes are the model's **output range**: a target outside it can
never be reached.

The **linear inverse of the major loop** fits one straight line
``u = a + b v`` through both branches (least squares) and inverts it,
``v = (y - a) / b`` within the window: the baseline a practitioner starts
from, blind to hysteresis.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import IdentifyError
from .effects import plan_effects
from .inverter import Inverter

#: Samples of the major loop per cell of the grid, each way.
POINTS_PER_CELL = 16


def settled_model(model):
    """``model`` without the effects that act over time or per run (creep, drifts): what a slow sweep sees."""
    plan = plan_effects(model.effects, "major loop")
    drop = {id(e) for e in plan.offsets + plan.inert}
    return replace(model, effects=tuple(e for e in model.effects if id(e) not in drop))


def major_loop(model, domain: tuple[float, float] | None = None,
               points_per_cell: int = POINTS_PER_CELL) -> tuple[np.ndarray, np.ndarray]:
    """``(v, y)``: the set-points (V) of the sweep up and back down and the model's readings (um), ``(2n,)``."""
    g = model.grid
    lo, hi = (g.v_min, g.v_max) if domain is None else domain
    n = max(2, int(points_per_cell * g.levels * (hi - lo) / (g.v_max - g.v_min)) + 1)
    up = np.linspace(lo, hi, n)
    v = np.concatenate([up, up[::-1]])
    inv = Inverter(settled_model(model), domain=(lo, hi))
    y = np.array([inv.apply(float(x)) for x in v])
    return v, y


def output_range(model, domain: tuple[float, float] | None = None) -> tuple[float, float]:
    """The lowest and highest reading (um) the model can give on ``domain`` (V): the major loop's extremes."""
    _, y = major_loop(model, domain)
    return float(np.min(y)), float(np.max(y))


@dataclass(frozen=True)
class LinearInverse:
    """``u = intercept_um + slope_um_per_V v``, fitted to the major loop on ``[lo, hi]`` V, inverted."""

    intercept_um: float
    slope_um_per_V: float
    lo: float
    hi: float

    @classmethod
    def of_model(cls, model, domain: tuple[float, float] | None = None) -> "LinearInverse":
        g = model.grid
        lo, hi = (g.v_min, g.v_max) if domain is None else domain
        v, y = major_loop(model, (lo, hi))
        b, a = np.polyfit(v, y, 1)
        if not np.isfinite(b) or b == 0.0:
            raise IdentifyError("the model's major loop has no slope: it has no linear inverse")
        return cls(float(a), float(b), float(lo), float(hi))

    def voltages(self, targets: np.ndarray) -> np.ndarray:
        """Set-points (V) for ``targets`` (um), ``(n,)``, within ``[lo, hi]``."""
        v = (np.asarray(targets, dtype=float) - self.intercept_um) / self.slope_um_per_V
        return np.clip(v, self.lo, self.hi)
