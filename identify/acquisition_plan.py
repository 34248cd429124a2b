"""Which points of an input sequence must settle, and which to measure (compressive acquisition).

**Reversal points.**  The memory curve of a Preisach operator only keeps the
extremes of the input history: while the input keeps moving in one
direction, every intermediate value is wiped out by the next one.  So in a
monotone run between two reversals the intermediate points do not need to
be reached at rest -- the thermal lag of the VO2 beam moves its
temperature monotonically from one set-point towards the next, through the
same values -- but the point where the input turns back must be reached
fully, or the extreme written into the memory curve is wrong for every
later point.  :func:`reversal_points` finds them.

The run starts from negative saturation and the heater returns to 0 V after
it, so both ends count as "below everything": the first point is always
reached by a rise, and the last point is a reversal when it was reached by
a rise.  On a plateau (equal consecutive inputs) the last point of the
plateau is the one the input turns at.

**Compressive plan.**  :func:`compressive_plan` measures ``M`` points in
all: every point that must be measured (the reversal points, which settle
anyway) plus ``M - R`` more chosen uniformly at random with a seed, as the
paper chooses its random subsets of rows.
"""

from __future__ import annotations

import numpy as np

from .errors import IdentifyError
from .sampling import choose_rows


def reversal_points(inputs: np.ndarray) -> np.ndarray:
    """Bool mask ``(n,)``: where the input sequence ``inputs`` ``(n,)`` changes direction.

    The sequence is taken to start from and return to below every input
    (negative saturation, heater off); see the module docstring.
    """
    v = np.asarray(inputs, dtype=float).reshape(-1)
    n = v.size
    if n == 0:
        return np.zeros(0, bool)
    if not np.all(np.isfinite(v)):
        raise IdentifyError("inputs must be finite")
    # step[k]: direction of the move into point k (k < n); step[n]: the move after the last point
    step = np.sign(np.diff(np.concatenate([[-np.inf], v, [-np.inf]])))
    idx = np.arange(n + 1)
    moved = step != 0
    # direction of the last real move into each point (step[0] = +1, so there always is one)
    last_in = step[np.maximum.accumulate(np.where(moved, idx, 0))]
    # direction of the first real move out of each point (step[n] = -1, so there always is one)
    first_out = step[np.minimum.accumulate(np.where(moved, idx, n)[::-1])[::-1]]
    return moved[1:] & (last_in[:n] != first_out[1:])


def compressive_plan(
    n: int, m: int | None, seed: int | None, always: np.ndarray | None = None
) -> np.ndarray:
    """Bool mask ``(n,)`` of the points to measure: all of them, or ``m`` in all.

    ``always`` (bool mask ``(n,)``) marks the points that are measured in any
    case (the reversal points); the other ``m - sum(always)`` are chosen
    uniformly at random among the rest with ``seed``.  ``m = None`` measures
    every point.
    """
    if m is None:
        return np.ones(n, bool)
    must = np.zeros(n, bool) if always is None else np.asarray(always, dtype=bool).reshape(-1)
    if must.size != n:
        raise IdentifyError(f"the mask of points always measured has {must.size} entries for {n} points")
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or not 1 <= m <= n:
        raise IdentifyError(f"the number of measured points M={m} must be between 1 and N={n}")
    r = int(must.sum())
    if m < r:
        raise IdentifyError(
            f"M={m} is fewer than the {r} reversal points, which are always measured "
            f"(they must settle anyway); use M >= {r}"
        )
    plan = np.zeros(n, bool)
    plan[choose_rows(n, m, seed, tuple(int(k) for k in np.flatnonzero(must)))] = True
    return plan
