"""``ambient_drift``: the room temperature drifts, shifting where the transition happens on the input.

The beam's temperature rise is Joule heating, ``~ v^2``; a change of the
room temperature adds to it, so the input the memory curve sees is
``x = sqrt(v^2 + d(t))``, ``d`` in V^2 (a temperature in units of the
heater's kelvin per V^2), a smooth function of session time per run (a
penalised cubic spline, :mod:`identify.effects.bases`) -- or, a setting
(``form``), the room changes the rise per watt: ``x = |v| sqrt(1 + d(t))``.  The thermal term
follows the heater, not the room.  A per-run nuisance: a stored model
knows the drift of the runs it was fitted on, by name, and nothing of
another run's.  The first run's drift has zero mean over its measured
points: its mean room temperature is the reference the density is
identified at (a constant offset of the input is the density's to absorb).

Its columns are secants of the model's output in each spline coefficient
(the thermal term held): a spline moves the input only where it lives in
time, so the memory's past extrema keep the room temperature they were
reached at.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..runs import Run
from .base import INPUT, Columns, Context, Effect, needs_heater, needs_time
from .bases import (DRIFT_KNOTS_S, KNOT_S, centred_first, drift_bases, per_run_columns, run_splines, spline_of,
                    splines_at)

#: Weights of the splines' roughness penalty tried in the diagnosis (relative to the data): from as
#: strong as the data to nearly a straight line per run.  Never none: an unpenalised coefficient that
#: the training blocks hardly see extrapolates wildly into the held-out block.
SMOOTHING = (0.01, 0.1, 1.0, 10.0, 100.0, 1000.0)
#: Weight of the roughness penalty when a model is fitted with a drift (``rig identify --with``): the
#: middle of :data:`SMOOTHING`.  Unpenalised, a drift's first spline trades with the cells that only
#: the run's first points switch (and with ``mu0``), and a model stored with it mispredicts other runs.
FIT_SMOOTHING = 1.0
#: Secant step in the drift, in squared cells (shift) or cells per range (gain).
SECANT = 1e-3
#: How the room moves the transition (a setting): an added temperature (``shift``, in heater power), or a
#: change of the temperature rise per watt (``gain``, relative).
FORMS = ("shift", "gain")


def drift_settings(**extra: float | str) -> list[dict[str, float]]:
    """The settings a drift's diagnosis tries: every roughness weight of :data:`SMOOTHING` at every knot
    spacing of :data:`~identify.effects.bases.DRIFT_KNOTS_S`, with ``extra`` (a form)."""
    return [{**extra, "knot_s": k, "smoothing": w} for k in DRIFT_KNOTS_S for w in SMOOTHING]


class AmbientDrift(Effect):
    name = "ambient_drift"
    summary = "the room temperature drifts, shifting where the transition happens (on the input)"
    look_alikes = ("the heater's rise per volt drifting with use (its film annealing or ageing)",
                   "the transition moving with the film's use (training)")
    stage = INPUT
    per_run = True
    must_record = (needs_heater, needs_time)
    #: On a run it was not fitted on it is unknown and changes nothing.
    inversion = "inert"
    absolute = True

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        runs = params.get("runs")
        if not isinstance(runs, dict):
            raise IdentifyError(f"effect {self.name!r} needs 'runs': {{run name: spline}}")
        form = params.get("form", "shift")
        if form not in FORMS:
            raise IdentifyError(f"effect {self.name!r}: form must be one of {', '.join(FORMS)}")
        return {"runs": runs, "form": form}

    @property
    def form(self) -> str:
        return (self.params or {}).get("form", "shift")

    def settings_grid(self) -> list[dict[str, float]]:
        return [s for f in FORMS for s in drift_settings(form=f)]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"form": f, "smoothing": FIT_SMOOTHING} for f in FORMS]

    def with_setting(self, setting: dict[str, float], ctx: Context | None = None) -> "AmbientDrift":
        if self.fitted:
            return self
        return AmbientDrift({"runs": {}, "form": setting.get("form", "shift")})

    def drift(self, run: Run) -> np.ndarray:
        """This run's ``d(t)`` (V^2) at every point, ``(n,)`` (zeros for a run it was not fitted on)."""
        entry = (self.params or {}).get("runs", {}).get(run.name)
        return np.zeros(run.n) if entry is None else spline_of(entry, run.t_s)

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        d = self.drift(run)
        if not np.any(d):
            return x
        return moved_input(x, d, self.form)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """Secants of the model's output in each spline coefficient, at the current drift (none in the
        diagnosis and a joint fit's first step): each spline moves the input only where it lives in
        time, so the memory's past extrema keep the room temperature they were reached at.  (A uniform
        shift of the whole history times the splines, the first-order shortcut, spanned 81-85 % of
        the true drift's trace on the withheld benchmark's dev devices, against 90-96 %.)"""
        return self._columns(ctx, setting, centre_first=True)

    def nuisance_columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """On another run the drift is relative to the identification run's mean: a constant too."""
        return self._columns(ctx, setting, centre_first=False)

    def _columns(self, ctx: Context, setting: dict[str, float], centre_first: bool) -> Columns:
        # the first run's mean ambient is the density's reference: its drift has zero mean
        knot = setting.get("knot_s", KNOT_S)
        bases = drift_bases(ctx.runs, knot, centre_first)
        form = self.form if self.fitted else setting.get("form", "shift")
        blocks = [self._secants(ctx, i, b, form) for i, b in enumerate(bases)]
        return per_run_columns(ctx.runs, blocks, "spline", setting.get("smoothing", 0.0), knot)

    def _secants(self, ctx: Context, i: int, basis: np.ndarray, form: str) -> np.ndarray:
        run = ctx.runs[i]
        x = ctx.inputs[i]
        before = ctx.thermal[i]  # the input before this effect: the heater voltage, or the lagged one
        step = SECANT * (ctx.grid.step ** 2 if form == "shift" else ctx.grid.step / (ctx.grid.v_max - ctx.grid.v_min))
        d = self.drift(run)
        # the current input and, per spline, the input moved by it: one batched replay, not one per spline
        moved = np.vstack([x[None, :], moved_input(before[None, :], d[None, :] + step * basis.T, form)])
        out = ctx.responses(i, moved)
        return np.ascontiguousarray(((out[1:] - out[0]) / step).T)

    def coefficients(self, ctx: Context) -> np.ndarray:
        runs = (self.params or {}).get("runs", {})
        out = []
        for r in ctx.runs:
            entry = runs.get(r.name)
            knots = entry.get("knots_s") if entry is not None else None
            d = splines_at(np.asarray(knots, float) if knots is not None else None, r.t_s[:1]).shape[1] \
                if entry is not None else drift_bases((r,), KNOT_S, False)[0].shape[1]
            out.append(np.asarray(entry["coefficients"], float) if entry is not None and len(entry["coefficients"]) == d
                       else np.zeros(d))
        return np.concatenate(out)

    def with_fit(self, ctx, setting, coef, cols) -> "AmbientDrift":
        knot = setting.get("knot_s", KNOT_S)
        coef = centred_first(ctx.runs, cols, coef, knot)  # the first run's columns were centred: so is its drift
        previous = (self.params or {}).get("runs")
        form = self.form if self.fitted else setting.get("form", "shift")
        return AmbientDrift({"runs": {**(previous or {}), **run_splines(ctx.runs, cols, coef, knot_s=knot)},
                             "form": form})

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return {**drift_report(self.params, "V2" if self.form == "shift" else "gain", runs), "form": self.form}


def moved_input(x: np.ndarray, d: np.ndarray, form: str) -> np.ndarray:
    """The hysterons' input with the room's drift ``d``: ``sqrt(x^2 + d)`` (``shift``, ``d`` in V^2) or
    ``|x| sqrt(1 + d)`` (``gain``: the rise per watt changes by the fraction ``d``)."""
    if form == "gain":
        return np.abs(x) * np.sqrt(np.maximum(1.0 + d, 0.0))
    return np.sqrt(np.maximum(x * x + d, 0.0))


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
