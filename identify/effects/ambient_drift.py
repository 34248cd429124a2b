"""``ambient_drift``: the room temperature drifts, shifting where the transition happens on the input.

The beam's temperature rise is Joule heating, ``~ v^2``; a change of the
room temperature adds to it, so the input the memory curve sees is
``x = sqrt(v^2 + d(t))``, ``d`` in V^2 (a temperature in units of the
heater's kelvin per V^2), a smooth function of session time per run (a
penalised cubic spline, :mod:`identify.effects.bases`).  The thermal term
follows the heater, not the room.  A per-run nuisance: a stored model
knows the drift of the runs it was fitted on, by name, and nothing of
another run's.  The first run's drift has zero mean over its measured
points: its mean room temperature is the reference the density is
identified at (a constant offset of the input is the density's to absorb).

Linearised, a shift of a run's input history changes the output by ``J``
times the shift, ``J`` the model's sensitivity to a uniform input shift
(a central difference over half a cell, the thermal term held), so the
columns are ``J / (2 x) B(t)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..runs import Run
from .base import INPUT, Columns, Context, Effect, needs_heater, needs_time
from .bases import per_run_columns, run_splines, spline_of, time_splines

#: Weights of the splines' roughness penalty tried in the diagnosis (relative to the data): from as
#: strong as the data to nearly a straight line per run.  Never none: an unpenalised coefficient that
#: the training blocks hardly see extrapolates wildly into the held-out block.
SMOOTHING = (0.01, 0.1, 1.0, 10.0, 100.0, 1000.0)
#: Weight of the roughness penalty when a model is fitted with a drift (``rig identify --with``): the
#: middle of :data:`SMOOTHING`.  Unpenalised, a drift's first spline trades with the cells that only
#: the run's first points switch (and with ``mu0``), and a model stored with it mispredicts other runs.
FIT_SMOOTHING = 1.0
#: Below this fraction of the range the input counts as near zero in ``J / (2 x)``.
LOW_INPUT = 0.05
#: Secant step in the drift, in squared cells.
SECANT = 1e-3


def sensitivity(ctx: Context, i: int) -> np.ndarray:
    """``J / (2 x)`` (um/V^2) at every point of run ``i``, ``(n_i,)``: the output change per V^2 of ``d``."""
    x = ctx.inputs[i]
    delta = 0.5 * ctx.grid.step
    th = ctx.thermal[i]
    j = (ctx.response(i, x + delta, th) - ctx.response(i, x - delta, th)) / (2.0 * delta)
    v_low = LOW_INPUT * (ctx.grid.v_max - ctx.grid.v_min)
    return j / (2.0 * np.maximum(np.abs(x), v_low))


class AmbientDrift(Effect):
    name = "ambient_drift"
    summary = "the room temperature drifts, shifting where the transition happens (on the input)"
    stage = INPUT
    per_run = True

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        runs = params.get("runs")
        if not isinstance(runs, dict):
            raise IdentifyError(f"effect {self.name!r} needs 'runs': {{run name: spline}}")
        return {"runs": runs, **{k: v for k, v in params.items() if k != "runs"}}

    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        return needs_heater(runs) or needs_time(runs)

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"smoothing": w} for w in SMOOTHING]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"smoothing": FIT_SMOOTHING}]

    def drift(self, run: Run) -> np.ndarray:
        """This run's ``d(t)`` (V^2) at every point, ``(n,)`` (zeros for a run it was not fitted on)."""
        entry = (self.params or {}).get("runs", {}).get(run.name)
        return np.zeros(run.n) if entry is None else spline_of(entry, run.t_s)

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        d = self.drift(run)
        if not np.any(d):
            return x
        return np.sqrt(np.maximum(x * x + d, 0.0))

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """Linearised at a model without the drift (the diagnosis; a joint fit's first step): the
        sensitivity to a uniform input shift times the splines.  Once fitted: secants of the model's
        output in each spline coefficient (exact steps near the solution)."""
        return self._columns(ctx, setting, centre_first=True)

    def nuisance_columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """On another run the drift is relative to the identification run's mean: a constant too."""
        return self._columns(ctx, setting, centre_first=False)

    def _columns(self, ctx: Context, setting: dict[str, float], centre_first: bool) -> Columns:
        bases = [time_splines(r) for r in ctx.runs]
        if centre_first:  # the first run's mean ambient is the density's reference: its drift has zero mean
            first = ctx.runs[0]
            bases[0] = bases[0] - bases[0][first.rows].mean(axis=0)
        if not self.fitted:
            blocks = [sensitivity(ctx, i)[:, None] * b for i, b in enumerate(bases)]
        else:
            blocks = [self._secants(ctx, i, b) for i, b in enumerate(bases)]
        return per_run_columns(ctx.runs, blocks, "spline", setting.get("smoothing", 0.0))

    def _secants(self, ctx: Context, i: int, basis: np.ndarray) -> np.ndarray:
        run = ctx.runs[i]
        x = ctx.inputs[i]
        before = ctx.thermal[i]  # the input before this effect: the heater voltage, or the lagged one
        base = ctx.response(i, x)
        step = SECANT * ctx.grid.step ** 2
        out = np.empty(basis.shape)
        for j in range(basis.shape[1]):
            moved = np.sqrt(np.maximum(before * before + self.drift(run) + step * basis[:, j], 0.0))
            out[:, j] = (ctx.response(i, moved) - base) / step
        return out

    def with_fit(self, ctx, setting, coef, cols) -> "AmbientDrift":
        coef = np.asarray(coef, dtype=float).copy()
        first = ctx.runs[0]
        mine = np.asarray(cols.run_of) == 0
        if mine.any():  # the first run's columns were centred: so is its step (its splines add up to one)
            step = coef[mine]
            coef[mine] = step - time_splines(first)[first.rows].mean(axis=0) @ step
        previous = (self.params or {}).get("runs")
        return AmbientDrift({"runs": {**(previous or {}), **run_splines(ctx.runs, cols, coef, previous)}})

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return drift_report(self.params, "V2", runs)


def drift_report(params: dict[str, Any] | None, unit: str, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
    """Each run's drift in physical terms: rms about its mean, range and end-to-end change over the run's
    measured points (over the spline's span when the run is not given), with its knots and coefficients."""
    out: dict[str, Any] = {}
    by_name = {r.name: r for r in runs}
    for name, entry in (params or {}).get("runs", {}).items():
        knots = entry.get("knots_s")
        run = by_name.get(name)
        t = run.t_s[run.rows] if run is not None else (np.linspace(knots[0], knots[-1], 200) if knots else np.zeros(1))
        d = spline_of(entry, t)
        out[name] = {f"rms_{unit}": float(np.sqrt(np.mean((d - d.mean()) ** 2))), f"range_{unit}": float(np.ptp(d)),
                     f"change_{unit}": float(d[-1] - d[0]), **entry}
    return {"runs": out}
