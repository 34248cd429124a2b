"""Bases the effects share: B-splines of session time, piecewise-linear functions of the input.

* :func:`time_knots` / :func:`time_splines` -- cubic B-splines of a run's
  session time with knots every :data:`KNOT_S` seconds (the drifts);
* :func:`ramps` -- piecewise-linear functions of the input on a set of
  knots (the reversible component);
* :func:`per_run_columns` -- per-run nuisance columns, zero outside their run,
  with a second-difference roughness penalty on each run's coefficients.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..runs import Run
from .base import Columns

#: Knot spacing (s) of the drifts' cubic splines in session time (a penalised spline: the roughness
#: penalty decides how wiggly a drift may be).
KNOT_S = 300.0
#: Degree of the drift splines.
DEGREE = 3


def time_knots(run: Run) -> np.ndarray | None:
    """The knots of :func:`time_splines` (None when the run's measured points share one time)."""
    tm = run.t_s[run.rows]
    lo, hi = float(tm.min()), float(tm.max())
    if hi <= lo:
        return None
    inner = np.linspace(lo, hi, int((hi - lo) // KNOT_S) + 2)
    return np.concatenate([[lo] * DEGREE, inner, [hi] * DEGREE])


def splines_at(knots: np.ndarray | None, t_s: np.ndarray) -> np.ndarray:
    """Cubic B-splines on ``knots`` at times ``t_s`` ``(n,)`` (clamped to the knots' span): ``(n, d)``.
    ``knots`` None: one constant function."""
    t = np.asarray(t_s, dtype=float)
    if knots is None:
        return np.ones((t.size, 1))
    from scipy.interpolate import BSpline

    return BSpline.design_matrix(np.clip(t, knots[0], knots[-1]), knots, DEGREE).toarray()


def time_splines(run: Run) -> np.ndarray:
    """Cubic B-splines of session time with knots every :data:`KNOT_S` over the run's measured points,
    ``(n, d)``; they add up to one, so the basis holds a constant offset."""
    return splines_at(time_knots(run), run.t_s)


def per_run_columns(runs: tuple[Run, ...], blocks: list[np.ndarray], what: str, smoothing: float = 0.0) -> Columns:
    """Per-run nuisance columns: run ``i`` gets ``blocks[i]`` ``(n_i, d_i)`` and zeros elsewhere;
    the roughness penalty is the squared second differences of each run's coefficients."""
    offsets = np.cumsum([0] + [b.shape[1] for b in blocks])
    k = int(offsets[-1])
    values, labels, run_of = [], [], []
    for i, (run, b) in enumerate(zip(runs, blocks)):
        v = np.zeros((run.n, k))
        v[:, offsets[i]:offsets[i + 1]] = b
        values.append(v)
        labels += [f"{run.name}:{what}{j}" for j in range(b.shape[1])]
        run_of += [i] * b.shape[1]
    rough = np.zeros((k, k))
    for i, b in enumerate(blocks):
        d = b.shape[1]
        if d >= 3:
            diff = np.diff(np.eye(d), n=2, axis=0)
            rough[offsets[i]:offsets[i + 1], offsets[i]:offsets[i + 1]] = diff.T @ diff
    return Columns(tuple(values), tuple(labels), (False,) * k, tuple(run_of), rough, smoothing)


def run_splines(runs: tuple[Run, ...], cols: Columns, coef: np.ndarray, previous: dict[str, Any] | None = None,
                ) -> dict[str, Any]:
    """Each run's spline (knots and coefficients, added to ``previous``'s where it has that run) from the
    per-run coefficients ``coef`` of :func:`per_run_columns`: ``{run name: {"knots_s", "coefficients"}}``."""
    out: dict[str, Any] = {}
    run_of = np.asarray(cols.run_of)
    for i, run in enumerate(runs):
        mine = np.asarray(coef, dtype=float)[run_of == i]
        if not mine.size:
            continue
        knots = time_knots(run)
        old = (previous or {}).get(run.name)
        if old is not None and len(old["coefficients"]) == mine.size:
            mine = mine + np.asarray(old["coefficients"], dtype=float)
        out[run.name] = {"knots_s": None if knots is None else [float(x) for x in knots],
                         "coefficients": [float(x) for x in mine]}
    return out


def spline_of(entry: dict[str, Any], t_s: np.ndarray) -> np.ndarray:
    """A stored run's spline (an entry of :func:`run_splines`) at times ``t_s`` ``(n,)``."""
    knots = entry.get("knots_s")
    coef = np.asarray(entry["coefficients"], dtype=float)
    return splines_at(None if knots is None else np.asarray(knots, dtype=float), t_s) @ coef


def ramps(knots: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(n, K - 1)``: ramp ``k`` rises linearly from 0 at ``knots[k]`` to 1 at ``knots[k + 1]`` (0 below,
    1 above).  A sum ``sum d_k ramp_k`` is the piecewise-linear function with value 0 at ``knots[0]``
    and increments ``d_k`` between knots (constant beyond the ends)."""
    t = np.asarray(knots, dtype=float)
    x = np.asarray(v, dtype=float)[:, None]
    return np.clip((x - t[None, :-1]) / np.diff(t)[None, :], 0.0, 1.0)
