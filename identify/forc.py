"""First-order reversal curves (FORCs) and their Everett function on the grid's walls.

A FORC starts from positive saturation: the input comes down from at or
above ``v_max`` to a *reversal* input ``r`` and the output is then measured
on the way back up, at inputs ``x >= r``.  For a Preisach model (equation
(22)) the output there is::

    u(r, x) = mu0 + c_d x + M_s - 2 E(r, x),
    E(r, x) = mass of the hysterons with beta > r and alpha > x,

``M_s`` the total mass: after the descent every hysteron with ``beta > r``
is down, the ascent to ``x`` switches back those with ``alpha < x``.  ``E``
is Mayergoyz's Everett function of this protocol.  The mass of the cell
``alpha in (v_i, v_{i+1})``, ``beta in (v_j, v_{j+1})`` (``j < i``) is its
second difference, and the terms ``mu0 + c_d x + M_s`` cancel::

    mu_ij = -1/2 [u(v_j, v_i) - u(v_{j+1}, v_i) - u(v_j, v_{i+1}) + u(v_{j+1}, v_{i+1})]

(the FORC distribution ``-1/2 d2u / dr dx`` integrated over the cell).
Measured FORCs do not sit on the walls: :func:`forc_surface` interpolates
``u`` linearly along each curve at the walls, then linearly across the
curves' reversal inputs.  Where the curves do not reach, ``u`` is unknown
(NaN) and so are the cells that need it.

The diagonal cells are different: ``E(v_i, v_i) - E(v_i, v_{i+1})`` is
the slope of a curve just after its reversal, where the reversible
``c_d x`` term and the diagonal hysterons cannot be told apart by
differences; :mod:`identify.methods.forc_everett` fits them instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import MethodNotApplicable
from .grid import Grid


@dataclass(frozen=True, eq=False)
class ReversalCurves:
    """The measured points of each FORC, by curve.

    ``numbers`` ``(K,)`` the curve numbers; ``reversal`` ``(K,)`` each
    curve's reversal input (its first applied point); ``inputs[k]`` and
    ``outputs[k]`` the measured points of curve ``k``, sorted by input;
    ``starts_at_reversal[k]``: whether the reversal point itself was measured.
    """

    numbers: np.ndarray
    reversal: np.ndarray
    inputs: tuple[np.ndarray, ...]
    outputs: tuple[np.ndarray, ...]
    starts_at_reversal: np.ndarray

    def __len__(self) -> int:
        return int(self.numbers.size)


def _blocks(curves: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Curve numbers and the first and last applied row of each (rows of a curve must be contiguous)."""
    on = np.flatnonzero(curves >= 0)
    if on.size == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.int64)
    labels = curves[on]
    breaks = np.flatnonzero((np.diff(on) != 1) | (np.diff(labels) != 0)) + 1
    starts = on[np.concatenate([[0], breaks])]
    stops = on[np.concatenate([breaks - 1, [on.size - 1]])]
    numbers = curves[starts]
    values, counts = np.unique(numbers, return_counts=True)
    if np.any(counts > 1):
        raise MethodNotApplicable(f"curve {int(values[counts > 1][0])} is not one contiguous run of applied points")
    return numbers, starts, stops


def reversal_curves(
    grid: Grid,
    inputs: np.ndarray,
    curves: np.ndarray | None,
    rows: np.ndarray,
    measured: np.ndarray,
    method: str = "everett",
) -> ReversalCurves:
    """Group the measured ``rows`` by FORC and check that each curve is one.

    ``inputs`` ``(n,)`` every applied input; ``curves`` ``(n,)`` the curve
    of every applied point (-1: none); ``rows`` ``(M,)`` the measured rows
    and ``measured`` ``(M,)`` their outputs.  A curve is a first-order
    reversal curve of this grid when its applied points are contiguous and
    rising, and the input came down to its first point monotonically from
    at or above the grid's top ``v_max`` (positive saturation).  Raises
    :class:`MethodNotApplicable` naming the problem.
    """
    if curves is None:
        raise MethodNotApplicable(
            f"{method} identifies from first-order reversal curves (FORC data), and these data hold no curves; "
            "it applies to sessions imported from a FORC measurement (rig import --format micromag)"
        )
    v = np.asarray(inputs, dtype=float)
    curves = np.asarray(curves, dtype=np.int64)
    rows = np.asarray(rows, dtype=np.int64)
    y = np.asarray(measured, dtype=float)
    on_curve = curves[rows] >= 0
    if not np.any(on_curve):
        raise MethodNotApplicable(f"{method}: none of the {rows.size} measured points lies on a curve")
    numbers, starts, stops = _blocks(curves)
    wanted = np.unique(curves[rows[on_curve]])
    keep = np.isin(numbers, wanted)
    numbers, starts, stops = numbers[keep], starts[keep], stops[keep]
    top = float(grid.v_max) - 1e-9 * (grid.v_max - grid.v_min)
    tol = 1e-9 * (grid.v_max - grid.v_min)
    saturated = np.flatnonzero(v >= top)
    ins, outs, at_rev = [], [], []
    for c, a, b in zip(numbers, starts, stops):
        before = saturated[saturated < a]
        if before.size == 0:
            raise MethodNotApplicable(
                f"{method}: curve {c} does not start from positive saturation: the input never reaches the "
                f"grid's top ({grid.v_max:g}) before it; use a grid whose top is within the saturation field"
            )
        descent = v[before[-1] : a + 1]
        if np.any(np.diff(descent) > tol):
            raise MethodNotApplicable(
                f"{method}: curve {c} is not a first-order reversal curve: the input rises on the way down "
                "from saturation to its reversal point"
            )
        mine = (rows >= a) & (rows <= b)
        order = np.argsort(v[rows[mine]], kind="stable")
        ins.append(v[rows[mine]][order])
        outs.append(y[mine][order])
        at_rev.append(bool(np.any(rows[mine] == a)))
    return ReversalCurves(numbers, v[starts], tuple(ins), tuple(outs), np.array(at_rev, bool))


def forc_surface(curves: ReversalCurves, grid: Grid) -> np.ndarray:
    """``U[j, i] = u(r = v_j, x = v_i)`` on the walls, ``(L+1, L+1)``; NaN where the curves do not reach.

    Along each curve ``u`` is interpolated linearly at the walls inside its
    measured range; a curve measured from its reversal point is extended
    below it at constant output by up to one cell (the usual FORC extension,
    exact for the Everett function ``E``, off by ``c_d`` times the gap for
    ``u``), so that the diagonal corner ``u(v_i, v_i)`` can be interpolated
    across curves.  Across curves, at each wall ``v_i``, ``u`` is
    interpolated linearly in the reversal input between the curves that
    reach ``v_i``; only ``j <= i`` is filled.
    """
    walls = grid.walls
    L = grid.levels
    K = len(curves)
    along = np.full((K, L + 1), np.nan)
    for k in range(K):
        x, y = curves.inputs[k], curves.outputs[k]
        lo = x[0] - grid.step if curves.starts_at_reversal[k] else x[0]
        inside = (walls >= lo - 1e-12 * grid.step) & (walls <= x[-1] + 1e-12 * grid.step)
        along[k, inside] = np.interp(walls[inside], x, y)  # constant below x[0]
    U = np.full((L + 1, L + 1), np.nan)
    order = np.argsort(curves.reversal, kind="stable")
    r = curves.reversal[order]
    along = along[order]
    eps = 1e-12 * (grid.v_max - grid.v_min)
    for i in range(L + 1):
        ok = np.isfinite(along[:, i])
        if not np.any(ok):
            continue
        rr, uu = r[ok], along[ok, i]
        j = np.arange(i + 1)
        inside = (walls[j] >= rr[0] - eps) & (walls[j] <= rr[-1] + eps)
        U[j[inside], i] = np.interp(walls[j[inside]], rr, uu)
    return U


def everett_cells(grid: Grid, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Off-diagonal cell weights from the second differences of ``U`` (module docstring).

    Returns ``(mu, known)``, each ``(n_cells,)`` in parameter order: ``mu``
    is 0 on the diagonal and wherever a corner of the cell is unknown
    (``known`` False there).
    """
    i, j = grid.cell_alpha, grid.cell_beta
    off = i > j
    mu = np.zeros(grid.n_cells)
    known = np.zeros(grid.n_cells, bool)
    io, jo = i[off], j[off]
    d = -0.5 * (U[jo, io] - U[jo + 1, io] - U[jo, io + 1] + U[jo + 1, io + 1])
    ok = np.isfinite(d)
    idx = np.flatnonzero(off)
    mu[idx[ok]] = d[ok]
    known[idx[ok]] = True
    return mu, known
