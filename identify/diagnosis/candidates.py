"""The candidate library: the effects of :mod:`identify.effects`, scored as augmentations of the base model.

A candidate is an unfitted :class:`identify.effects.Effect`: its columns,
linearised at the base model (:class:`identify.effects.Context`), say how the
output would change per unit of each coefficient at every point of every
run (identification runs first, then check runs).  The diagnosis
(:mod:`identify.diagnosis.engine`) fits the coefficients jointly with the
base model and scores them on held-out check data; the same effect, fitted
by ``rig identify --with``, is what a stored model keeps.  There is no
second copy of any effect here.

Coefficients are either **structural** -- one physical constant of the
device, shared by every run (a lagging fraction, a creep spectrum) -- or
**per-run nuisance** -- something that differs from one run to the next (a
drift), whose columns are zero outside their run.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..effects import EFFECTS, Columns, Context, Effect, make_effect
from ..effects.bases import spline_of
from ..errors import IdentifyError
from ..registry import ByName
from .resolution import Resolution

#: The effects, by name, in the effects' order (every registered effect is a candidate).
CANDIDATES: ByName[type[Effect]] = EFFECTS
#: Every candidate's name: the effects, then ``resolution`` (the same model on a finer grid, which the
#: diagnosis builds for its runs: :mod:`~identify.diagnosis.resolution`).
NAMES: ByName[Any] = ByName(lambda: (*EFFECTS.values(), Resolution))
#: Candidates are the effects (and the resolution candidate); the name is kept for the diagnosis's vocabulary.
Candidate = Effect


def summary(name: str) -> str:
    """One line saying what candidate ``name`` is."""
    return Resolution.summary if name == Resolution.name else CANDIDATES[name].summary


def library(names: list[str] | tuple[str, ...] | None = None) -> list[Effect]:
    """Unfitted effects by name (all when ``names`` is None)."""
    chosen = list(CANDIDATES) if names is None else list(names)
    unknown = [n for n in chosen if n.partition(":")[0] not in CANDIDATES]
    if unknown:
        raise IdentifyError(f"unknown effect(s) {', '.join(unknown)}; the library has {', '.join(NAMES)}")
    return [make_effect(n) for n in chosen]


def fitted_params(cand: Effect, ctx: Context, setting: dict[str, float], coef: np.ndarray, cols: Columns
                  ) -> dict[str, Any]:
    """A candidate's fit on all check data in physical terms (JSON-safe): the effect fitted with the
    coefficients ``coef`` ``(k,)`` of ``cols`` (linearised at the base model), as it reports itself."""
    fitted = cand.with_fit(ctx, setting, np.asarray(coef, dtype=float), cols)
    return fitted.report(ctx.runs)


def drift_at(run_params: dict[str, Any], t_s: np.ndarray) -> np.ndarray:
    """A fitted drift (one run's entry of a drift's ``params["runs"]``) at times ``t_s`` ``(k,)`` (s), in
    the drift's unit; constant beyond the run's measured times."""
    return spline_of(run_params, t_s)


__all__ = ["CANDIDATES", "NAMES", "Candidate", "summary", "Columns", "Context", "drift_at", "fitted_params", "library"]
