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
KNOT_S = 600.0
#: The knot spacings (s) a drift's diagnosis tries (a setting, chosen by cross-validation like the roughness
#: weight): a laser's pointing, a mount's slip or a thermostat's cycle can wander faster than ten minutes.
DRIFT_KNOTS_S = (600.0, 200.0)
#: Degree of the drift splines.
DEGREE = 3
#: At least this many measured points per knot span of a drift's splines (a run sparse in time gets wider spans).
POINTS_PER_SPAN = 4


def time_knots(run: Run, knot_s: float = KNOT_S) -> np.ndarray | None:
    """The knots of :func:`time_splines`, about every ``knot_s`` seconds over the run's measured points
    (None when they share one time)."""
    tm = run.t_s[run.rows]
    lo, hi = float(tm.min()), float(tm.max())
    if hi <= lo:
        return None
    # never more spans than a quarter of the measured points (a run of day-long dwells would otherwise
    # carry a spline coefficient every few minutes of nothing)
    spans = min(int((hi - lo) // knot_s) + 1, max(tm.size // POINTS_PER_SPAN, 1))
    inner = np.linspace(lo, hi, spans + 1)
    return np.concatenate([[lo] * DEGREE, inner, [hi] * DEGREE])


def splines_at(knots: np.ndarray | None, t_s: np.ndarray) -> np.ndarray:
    """Cubic B-splines on ``knots`` at times ``t_s`` ``(n,)`` (clamped to the knots' span): ``(n, d)``.
    ``knots`` None: one constant function."""
    t = np.asarray(t_s, dtype=float)
    if knots is None:
        return np.ones((t.size, 1))
    from scipy.interpolate import BSpline

    return BSpline.design_matrix(np.clip(t, knots[0], knots[-1]), knots, DEGREE).toarray()


def time_splines(run: Run, knot_s: float = KNOT_S) -> np.ndarray:
    """Cubic B-splines of session time with knots about every ``knot_s`` (default :data:`KNOT_S`) over the
    run's measured points, ``(n, d)``; they add up to one, so the basis holds a constant offset."""
    return splines_at(time_knots(run, knot_s), run.t_s)


def greville(run: Run, knot_s: float = KNOT_S) -> np.ndarray | None:
    """The Greville abscissae (s) of :func:`time_splines`' coefficients: a straight line in time has its
    coefficients on a straight line over them (None for a single constant function)."""
    knots = time_knots(run, knot_s)
    if knots is None:
        return None
    return np.array([knots[j + 1:j + 1 + DEGREE].mean() for j in range(knots.size - DEGREE - 1)])


def second_differences(x: np.ndarray) -> np.ndarray:
    """``(d - 2, d)``: second divided differences over the abscissae ``x`` ``(d,)`` (scaled by the mean
    spacing squared): zero exactly on coefficients that lie on a straight line over ``x``."""
    x = np.asarray(x, dtype=float)
    d = x.size
    out = np.zeros((max(d - 2, 0), d))
    h = np.diff(x)
    mean = float(np.mean(h)) if h.size else 1.0
    for i in range(d - 2):
        out[i, i] = 1.0 / h[i]
        out[i, i + 1] = -(1.0 / h[i] + 1.0 / h[i + 1])
        out[i, i + 2] = 1.0 / h[i + 1]
        out[i] *= 2.0 * mean ** 2 / (h[i] + h[i + 1])
    return out


def per_run_columns(runs: tuple[Run, ...], blocks: list[np.ndarray], what: str, smoothing: float = 0.0,
                    knot_s: float = KNOT_S) -> Columns:
    """Per-run nuisance columns: run ``i`` gets ``blocks[i]`` ``(n_i, d_i)`` and zeros elsewhere;
    the roughness penalty is the squared second differences of each run's coefficients -- divided
    differences over the Greville abscissae of its time splines, so a straight-line drift is free."""
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
    for i, (run, b) in enumerate(zip(runs, blocks)):
        d = b.shape[1]
        if d >= 3:
            x = greville(run, knot_s)
            diff = second_differences(x) if x is not None and x.size == d else np.diff(np.eye(d), n=2, axis=0)
            rough[offsets[i]:offsets[i + 1], offsets[i]:offsets[i + 1]] = diff.T @ diff
    return Columns(tuple(values), tuple(labels), (False,) * k, tuple(run_of), rough, smoothing)


def run_splines(runs: tuple[Run, ...], cols: Columns, coef: np.ndarray, previous: dict[str, Any] | None = None,
                knot_s: float = KNOT_S) -> dict[str, Any]:
    """Each run's spline (knots and coefficients, added to ``previous``'s where it has that run) from the
    per-run coefficients ``coef`` of :func:`per_run_columns`: ``{run name: {"knots_s", "coefficients"}}``."""
    out: dict[str, Any] = {}
    run_of = np.asarray(cols.run_of)
    for i, run in enumerate(runs):
        mine = np.asarray(coef, dtype=float)[run_of == i]
        if not mine.size:
            continue
        knots = time_knots(run, knot_s)
        old = (previous or {}).get(run.name)
        if old is not None and len(old["coefficients"]) == mine.size:
            mine = mine + np.asarray(old["coefficients"], dtype=float)
        out[run.name] = {"knots_s": None if knots is None else [float(x) for x in knots],
                         "coefficients": [float(x) for x in mine]}
    return out


def drift_bases(runs: tuple[Run, ...], knot_s: float = KNOT_S, centre_first: bool = True) -> list[np.ndarray]:
    """Each run's :func:`time_splines` ``(n_i, d_i)``; with ``centre_first`` the first run's centred on its
    measured points (its mean is a constant the model holds anyway: the bias, the scale, the reference
    room temperature)."""
    bases = [time_splines(r, knot_s) for r in runs]
    if centre_first and runs:
        first = runs[0]
        bases[0] = bases[0] - bases[0][first.rows].mean(axis=0)
    return bases


def centred_first(runs: tuple[Run, ...], cols: Columns, coef: np.ndarray, knot_s: float = KNOT_S) -> np.ndarray:
    """``coef`` of :func:`per_run_columns` built on centred bases (:func:`drift_bases`), with the first run's
    turned into coefficients of the plain splines (which add up to one): the same drift, mean zero."""
    coef = np.asarray(coef, dtype=float).copy()
    mine = np.asarray(cols.run_of) == 0
    if mine.any() and runs:
        first = runs[0]
        c = coef[mine]
        coef[mine] = c - time_splines(first, knot_s)[first.rows].mean(axis=0) @ c
    return coef


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
