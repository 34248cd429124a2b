"""Whether a run's points were at rest: settle replicates, and the points a longer dwell supersedes.

The paper's model is quasi-static: every reading is taken once the film
has settled at its set-point.  How long that takes is a multiple of a
thermal time constant the operator does not know (0.5 to 20 s on VO2
beams), so a run to a target error (``rig acquire --target-nrmse``) finds
its dwell as it goes:

* a **settle replicate** applies the previous set-point again and waits
  :data:`SETTLE_FACTOR` times the dwell.  The memory state is the same (the
  input did not move), so the two readings differ by noise alone if the
  first was at rest, and by the rest of the transient if it was not;
* :func:`unsettled` tests the replicate differences ``d_i`` (um) seen at
  the current dwell: at rest, ``sum d_i^2 / (2 sigma^2)`` is chi-squared
  with as many degrees of freedom (``sigma`` the noise of one point, um);
  above its :data:`SETTLE_QUANTILE` quantile the points were not at rest
  and the dwell is lengthened :data:`DWELL_STEP`-fold;
* the points measured at the shorter dwell are **superseded**
  (:func:`superseded`): they still moved the memory, but their readings
  are not quasi-static and no fit uses them.

Everything here is a function of recorded columns (the wait the run asked
of each point, ``asked_dwell_s``, and its kind), so ``rig identify`` reaches
the same points from the session as the run did; a pause lengthens a point's
recorded ``dwell_s``, not its asked wait.
"""

from __future__ import annotations

import numpy as np

#: A settle replicate waits this many times the run's dwell.
SETTLE_FACTOR = 4.0
#: Settle replicates at a dwell before it is trusted: after each lengthening (and at the start) the next
#: design points are each followed by one until there are this many.
SETTLE_CHECKS = 3
#: The replicate differences' statistic is tested at this quantile of chi-squared (a run of ~20 tests
#: lengthens its dwell on noise alone with a chance of about 2 %).
SETTLE_QUANTILE = 0.999
#: Each lengthening multiplies the dwell by this.
DWELL_STEP = 2.0
#: A measured point whose wait is shorter than this share of the run's final dwell is superseded (the
#: dwell only grows, by :data:`DWELL_STEP`, so any share between 1/DWELL_STEP and 1 gives the same points;
#: below 1 it also tolerates the milliseconds a set-point write adds where a recorded wait stands in).
SUPERSEDED_SHARE = 0.9
#: The ``point_kind`` code of a replicate (as :mod:`rig.acquisition.adaptive` records it).
REPLICATE_CODE = 2


def unsettled(differences_um: np.ndarray, sigma_um: float) -> bool:
    """Whether settle-replicate differences ``(m,)`` (um; replicate minus the point it repeats) show the
    points were not at rest, for points of noise ``sigma_um`` (um): ``sum d^2 / (2 sigma^2)`` above the
    :data:`SETTLE_QUANTILE` quantile of chi-squared with ``m`` degrees of freedom.  No differences: False."""
    from scipy.stats import chi2  # here: importing identify does not pay for scipy.stats

    d = np.asarray(differences_um, dtype=float)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return False
    if not sigma_um > 0:
        raise ValueError(f"the point noise must be positive, got {sigma_um}")
    stat = float(np.sum(d * d)) / (2.0 * sigma_um**2)
    return stat > float(chi2.ppf(SETTLE_QUANTILE, d.size))


def superseded(waits_s: np.ndarray, kinds: np.ndarray, dwell_s: float | None = None) -> np.ndarray:
    """Which points ``(n,)`` bool a longer dwell superseded: ``waits_s`` (s, ``(n,)``) each point's wait (the
    one the run asked; a session without that column: the recorded one), ``kinds`` ``(n,)`` its
    ``point_kind`` code.  ``dwell_s`` (s): the run's dwell; None: the longest
    wait of a point that is not a replicate (replicates wait longer), which is the run's final dwell once
    a point has waited it -- a run that ends between a lengthening and its next point keeps, read from the
    session, the points the run had just dropped.  A point that waited less than
    :data:`SUPERSEDED_SHARE` of the dwell is superseded; replicates are judged like any point (one whose
    wait reaches the dwell is kept)."""
    w = np.asarray(waits_s, dtype=float)
    if dwell_s is None:
        dwell_s = final_dwell(w, kinds)
        if dwell_s is None:
            return np.zeros(w.shape, bool)
    return np.isfinite(w) & (w < SUPERSEDED_SHARE * dwell_s)


def final_dwell(waits_s: np.ndarray, kinds: np.ndarray) -> float | None:
    """The run's final dwell (s): the longest recorded wait ``(n,)`` of a point whose ``point_kind``
    ``(n,)`` is not a replicate (replicates wait longer); None before such a point."""
    w = np.asarray(waits_s, dtype=float)
    k = np.asarray(kinds)
    if w.shape != k.shape:
        raise ValueError(f"waits {w.shape} and kinds {k.shape} differ in shape")
    own = np.isfinite(w) & (k != REPLICATE_CODE)
    return float(w[own].max()) if own.any() else None
