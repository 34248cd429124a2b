"""A drift's twin on the clock of use: does the change follow the session's time, or the film's use?

The library's drifts (``baseline_drift``, ``gain_drift``, ``ambient_drift``)
are smooth functions of *session time*, one per run.  Mechanisms outside the
library -- the loop training or fatiguing with the cycles the film has gone
through, a heater film ageing with the power it has carried -- change the
same output in the same ways, but on the clock of *use*: they move when the
film switches or the heater is hot, and stand still through a long hold.  On
one check run the two clocks run nearly together, so a flexible drift
absorbs such a change and the diagnosis would name it.

The twin is the drift itself, at the setting the diagnosis chose for it,
with the run's time stamps replaced by the clock of use (:data:`CLOCKS`),
stretched onto the run's own time span (so its knots and smoothing mean what
they mean for the drift): ``cycles``, the film's switching, the cumulative
``|change|`` of the base model's phase-transition output (um) from the run's
first point.  A second clock, the heater's dose (``v^2 dt``), was left out:
the library's own drifts may follow it (an optical lever warmed by the
heater, the package's temperature), so a drift on it is no evidence against
them.

When the twin predicts the held-out check blocks clearly better than the
drift (:data:`~identify.diagnosis.verdict.Z_USE`), the change follows use,
not the clock, and no library effect is named for it (see
:mod:`~identify.diagnosis.verdict`).  A twin is never named: it stands for no
effect a model can store.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..effects import Columns, Context, Effect
from ..effects.base import needs_time
from ..runs import Run

#: The clocks of use a drift's twin may run on (see the module doc).
CLOCKS = ("cycles",)
#: How a twin is named in the evidence (never in a verdict): the drift's name and this suffix.
SUFFIX = "@use"


def is_session_drift(effect: Effect) -> bool:
    """Whether ``effect`` is a drift over session time (per run, acting over the time stamps): the
    effects a twin on the clock of use is made for."""
    return bool(effect.per_run and needs_time in effect.must_record)


def twin_name(drift: str) -> str:
    """The evidence's name for the twin of ``drift``."""
    return drift + SUFFIX


def use_increments(phase_um: np.ndarray, clock: str = "cycles") -> np.ndarray:
    """How much use each point of one run adds, ``(n,)``: the ``|change|`` of the phase-transition output
    ``phase_um`` ``(n,)`` into each point (``cycles``, um; none into the first)."""
    if clock != "cycles":
        raise ValueError(f"unknown clock {clock!r}; the clocks are {', '.join(CLOCKS)}")
    return np.abs(np.diff(np.asarray(phase_um, dtype=float), prepend=float(phase_um[0])))


def stretched(t_s: np.ndarray, increments: np.ndarray) -> np.ndarray:
    """The cumulative use of ``increments`` ``(n,)`` stretched onto the span of the time stamps ``t_s``
    ``(n,)`` (s): the first point at ``t_s[0]``, the last at ``t_s[-1]``, non-decreasing; the time stamps
    themselves when the run holds no use at all."""
    t = np.asarray(t_s, dtype=float)
    used = np.cumsum(increments)
    span = float(used[-1] - used[0]) if used.size else 0.0
    if not span > 0.0:
        return t.copy()
    return t[0] + (used - used[0]) / span * (t[-1] - t[0])


def reclocked(ctx: Context, clock: str) -> Context:
    """``ctx`` with every run's time stamps replaced by its use on ``clock``, stretched onto the run's
    span (:func:`stretched`); the phase output is the context's model's (its bias and thermal term off)."""
    m = ctx.model
    runs = []
    for i, run in enumerate(ctx.runs):
        phase = np.asarray(ctx.bare_output(i), dtype=float) - m.mu0 - m.c_d * np.asarray(ctx.thermal[i], dtype=float)
        runs.append(dataclasses.replace(run, t_s=stretched(run.t_s, use_increments(phase, clock))))
    return dataclasses.replace(ctx, runs=tuple(runs))


class UseClocked(Effect):
    """The twin of a session drift on a clock of use (see the module doc), scored like a candidate.

    ``drift``: the drift (an unfitted effect); ``setting``: the setting the diagnosis chose for it, which
    the twin keeps, on each of :data:`CLOCKS`.  Fitted, it holds the drift fitted on the reclocked
    runs and each run's clock by name, so that it acts on those runs as it was fitted.
    """

    summary = "a drift on the clock of use (the film's switching), not of time"

    def __init__(self, drift: Effect, setting: dict[str, Any] | None = None) -> None:
        super().__init__(None)
        self.drift = drift
        self.name = twin_name(drift.name)
        self.stage = drift.stage
        self.per_run = drift.per_run
        self.must_record = drift.must_record
        self.absolute = drift.absolute
        self.needs_output = drift.needs_output
        self.drift_setting = dict(setting or {})
        #: The clock by run name, once fitted: ``{run name: (n,) stretched use}``.
        self.clocks: dict[str, np.ndarray] = {}

    def settings_grid(self) -> list[dict[str, Any]]:
        return [{**self.drift_setting, "clock": c} for c in range(len(CLOCKS))]

    def _split(self, setting: dict[str, Any]) -> tuple[str, dict[str, Any]]:
        return CLOCKS[int(setting["clock"])], {k: v for k, v in setting.items() if k != "clock"}

    def columns(self, ctx: Context, setting: dict[str, Any]) -> Columns:
        clock, own = self._split(setting)
        if self.clocks:  # fitted: on the clocks it was fitted on
            return self.drift.columns(dataclasses.replace(ctx, runs=tuple(self._on_clock(r) for r in ctx.runs)), own)
        return self.drift.columns(reclocked(ctx, clock), own)

    def coefficients(self, ctx: Context) -> np.ndarray:
        return self.drift.coefficients(ctx)

    def with_fit(self, ctx: Context, setting: dict[str, Any], coef: np.ndarray, cols: Columns) -> "UseClocked":
        clock, own = self._split(setting)
        moved = reclocked(ctx, clock)
        out = UseClocked(type(self.drift)(), self.drift_setting)
        out.drift = self.drift.with_fit(moved, own, coef, cols)
        out.params = {"clock": clock, "drift": out.drift.params}
        out.clocks = {r.name: r.t_s for r in moved.runs}
        return out

    def _on_clock(self, run: Run) -> Run:
        t = self.clocks.get(run.name)
        return run if t is None or t.size != run.n else dataclasses.replace(run, t_s=t)

    def transform(self, run: Run, x: np.ndarray, *rest: Any) -> np.ndarray:
        return self.drift.transform(self._on_clock(run), x, *rest)

    def contribution(self, run: Run, *args: Any, **kwargs: Any) -> np.ndarray:
        return self.drift.contribution(self._on_clock(run), *args, **kwargs)

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return {"clock": (self.params or {}).get("clock")}
