"""``thermal_lag``: the beam is measured short of its set-point, because part of its heating is slow.

A resistive heater heats in proportion to ``v^2``; a thermal lag relaxes
the temperature, so the lag is a blend of squared voltages (a blend of
volts would make heating and cooling lag alike, which they do not).  A
fraction ``f`` of the rise follows a slow mode with time constant ``tau``
(s), which relaxes over each point's recorded dwell from where the
previous point left it::

    s_k = v_k^2 + (s_{k-1} - v_k^2) exp(-dwell_k / tau),     x_k = sqrt(v_k^2 + f (s_k - v_k^2))

``x`` is what the memory curve sees, and the thermal term follows it too
(the expansion follows the beam's temperature).  An unknown dwell counts
as fully settled.  Parameters: ``time_constant_s`` (a setting: the best of a grid,
then refined by Gauss--Newton steps in ``log tau``) and ``fraction`` (in
[0, 1] by its physics; fitted by Gauss--Newton steps).

Identifiable only from a run whose dwells differ: with one dwell ``d`` the
lag enters only as ``f exp(-d / tau)``, so ``tau`` and ``f`` cannot be told
apart -- and a model that cannot tell them apart cannot predict a run with
other dwells.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..grid import Grid
from ..runs import Run
from .base import INPUT, Columns, Context, Effect, finite, needs_heater, require_params, single_columns

#: Time constants tried first (s): from a fast beam to a slow package.
TIME_CONSTANTS_S = tuple(float(x) for x in np.geomspace(0.5, 60.0, 12))
#: Largest plausible lagging fraction (a whole rise arriving late).
MAX_FRACTION = 1.0
#: Step of the secant in the fraction.
STEP = 0.05
#: Step of the secant in ``log tau``.
LOG_STEP = 0.01
#: Relative spread below which two dwells count as the same.
SAME_DWELL = 1e-6


def slow_mode(run: Run, tau: float, v: np.ndarray | None = None) -> np.ndarray:
    """The slow mode's state (V^2) after each point's dwell, ``(n,)``; ``v`` defaults to the run's inputs."""
    v = run.inputs if v is None else v
    d = np.where(np.isfinite(run.dwell_s), run.dwell_s, np.inf)
    keep = np.exp(-np.clip(d, 0.0, None) / tau)
    power = v * v
    out = np.empty(run.n)
    prev = run.initial_V ** 2
    for k in range(run.n):
        prev = power[k] + (prev - power[k]) * keep[k]
        out[k] = prev
    return out


def lagged(run: Run, tau: float, fraction: float, v: np.ndarray | None = None) -> np.ndarray:
    """The lagged input (V), ``(n,)``, signed as ``v``."""
    v = run.inputs if v is None else v
    power = v * v
    return np.sign(v) * np.sqrt(np.maximum(power + fraction * (slow_mode(run, tau, v) - power), 0.0))


class ThermalLag(Effect):
    name = "thermal_lag"
    summary = "the dwell is too short for a thermal time constant: the beam is measured short of its set-point"
    stage = INPUT
    drives_thermal_term = True

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("time_constant_s", "fraction"), self.name)
        tau = finite(params, "time_constant_s", self.name)
        if tau <= 0:
            from ..errors import IdentifyError

            raise IdentifyError(f"effect {self.name!r}: time_constant_s must be > 0, got {tau}")
        return {"time_constant_s": tau, "fraction": finite(params, "fraction", self.name)}

    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        heater = needs_heater(runs)
        if heater is not None:
            return heater
        if not any(r.has_dwell for r in runs):
            return "no run records its dwell (set-point to readings), so there is nothing for a lag to act over"
        return None

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        why = self.applicable(runs)
        if why is not None:
            return why
        dwells = np.concatenate([r.dwell_s[r.rows] for r in runs])
        dwells = dwells[np.isfinite(dwells)]
        if dwells.size == 0 or np.ptp(dwells) <= SAME_DWELL * max(float(np.max(np.abs(dwells))), 1e-300):
            d = f" ({float(dwells[0]):g} s)" if dwells.size else ""
            return (f"every measured point has the same dwell{d}, so the lag's time constant and its size cannot be "
                    "told apart; record the identification run with varied dwells "
                    "(rig acquire --sequence damped --dwells 8,15,30,60)")
        return None

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"time_constant_s": tau} for tau in TIME_CONSTANTS_S]

    def with_setting(self, setting: dict[str, float], ctx: Context | None = None) -> "ThermalLag":
        if self.fitted:
            return self
        return ThermalLag({"time_constant_s": setting["time_constant_s"], "fraction": 0.0})

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        p = self.params
        if not p or p["fraction"] == 0:
            return x
        return lagged(run, p["time_constant_s"], p["fraction"], x)

    def _point(self, setting: dict[str, float]) -> tuple[float, float]:
        """``(tau, f)`` the columns are taken at: this fit's, else the setting's time constant and no lag."""
        if self.fitted:
            return self.params["time_constant_s"], self.params["fraction"]
        return setting["time_constant_s"], 0.0

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """The secant in the fraction; once the lag is fitted and nonzero, also in ``log tau`` (so the
        joint fit refines the time constant by Gauss--Newton steps too)."""
        tau, f0 = self._point(setting)
        with_tau = self.fitted and f0 > 0
        scale = ctx.grid.v_max - ctx.grid.v_min
        values = []
        for i, run in enumerate(ctx.runs):
            here = lagged(run, tau, f0)
            moved = lagged(run, tau, f0 + STEP)
            if np.max(np.abs(moved - here)) <= 1e-12 * scale:
                values.append(np.zeros((run.n, 2 if with_tau else 1)))
                continue
            base = ctx.response(i, here, here)
            cols = [(ctx.response(i, moved, moved) - base) / STEP]
            if with_tau:
                slower = lagged(run, tau * np.exp(LOG_STEP), f0)
                cols.append((ctx.response(i, slower, slower) - base) / LOG_STEP)
            values.append(np.stack(cols, axis=1))
        labels = ("fraction", "log_time_constant") if with_tau else ("fraction",)
        return single_columns(ctx.runs, values, labels, (not self.fitted,) + ((False,) if with_tau else ()))

    def with_fit(self, ctx, setting, coef, cols) -> "ThermalLag":
        tau, f0 = self._point(setting)
        if len(coef) > 1:  # a Gauss--Newton step in log tau, at most a factor e
            tau *= float(np.exp(np.clip(coef[1], -1.0, 1.0)))
        # a lagging fraction is between none and the whole rise
        fraction = float(np.clip(f0 + coef[0], 0.0, MAX_FRACTION))
        return ThermalLag({"time_constant_s": float(tau), "fraction": fraction})

    def bounds(self) -> dict[str, float]:
        return {"fraction": MAX_FRACTION}
