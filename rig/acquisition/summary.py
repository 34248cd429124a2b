"""What a run did, and the time compressive acquisition saved, from the session file alone.

The time a point took is the difference of successive ``t_s`` (the first
from the start of the run): set-point, wait, readings and recording.  A run
that measures every point would have spent, at each point it did not
measure, what its measured non-reversal points typically took (their
median; the measured points if every one is a reversal):

    full_time = sum(time of measured points) + (unmeasured points) x median

so ``time_saved = full_time - rig_time`` is exactly ``unmeasured x (dwell -
transit)`` for a fixed dwell on a virtual clock, and an estimate on a real
bench.  Both are rig-clock times (virtual on the simulated device).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from identify.acquisition_plan import reversal_points
from sessions import ADAPTIVE_KIND, SampleFlag, Session

from .runner import RunOutcome


def time_budget(t_s: np.ndarray, measured: np.ndarray, reversals: np.ndarray) -> tuple[float, float]:
    """``(rig_time_s, full_time_s)`` of recorded points: ``t_s`` (s), ``measured`` and ``reversals`` bool, all ``(n,)``."""
    t = np.asarray(t_s, dtype=float)
    if t.size == 0:
        return 0.0, 0.0
    d = np.diff(t, prepend=0.0)
    m = np.asarray(measured, dtype=bool)
    typical_pool = d[m & ~np.asarray(reversals, dtype=bool)]
    if typical_pool.size == 0:
        typical_pool = d[m]
    typical = float(np.median(typical_pool)) if typical_pool.size else float("nan")
    rig_time = float(t[-1])
    unmeasured = int((~m).sum())
    full = float(d[m].sum()) + unmeasured * typical if unmeasured else rig_time
    return rig_time, full


def summarise(session: Session, outcome: RunOutcome) -> dict[str, Any]:
    """The summary ``rig acquire`` prints (``--json`` keys, see the README)."""
    exc = session.excitation
    rows = session.samples
    n = rows.size
    rev = reversal_points(exc.inputs)
    rig_time, full = time_budget(rows["t_s"], rows["measured"], rev[:n])
    saved = full - rig_time
    return {
        "session": str(session.path),
        "status": session.status.value,
        "excitation": exc.kind,
        "levels": exc.levels,
        "v_min": exc.v_min,
        "v_max": exc.v_max,
        "thermal_term": exc.thermal_term,
        "n_points": exc.n_points,
        "n_applied": int(n),
        "n_measured": int(rows["measured"].sum()),
        "n_planned_measured": int(exc.measure.sum()),
        "n_reversals": int(rev.sum()),
        "n_settled": int(rows["settled"].sum()),
        "n_timeouts": int(np.count_nonzero(rows["flags"] & SampleFlag.DWELL_TIMEOUT)),
        "n_reconnected": int(np.count_nonzero(rows["flags"] & SampleFlag.RECONNECTED)),
        "n_retried": int(np.count_nonzero(rows["flags"] & SampleFlag.READ_RETRIED)),
        "resumed": outcome.start > 0 or any(e.event == "reopened" for e in session.events),
        "n_replayed": outcome.replayed,
        "dwell": exc.dwell,
        "clock": session.driver.get("clock"),
        "rig_time_s": rig_time,
        "full_time_s": full,
        "time_saved_s": saved,
        "time_saved_fraction": saved / full if full > 0 else 0.0,
        "wall_s": outcome.wall_s,
        "message": outcome.message,
        "identify_recipe": None if session.recipe is None else session.recipe.to_dict(),
        **_adaptive(session),
        **({"rig_time_plan": session.excitation.extra["rig_time_plan"]}
           if "rig_time_plan" in session.excitation.extra else {}),
    }


def _adaptive(session: Session) -> dict[str, Any]:
    """A run to a target error (``rig acquire --target-nrmse``): its target, the last predicted check nRMSE
    and whether it reached the target; for a run that found its own dwell, its first and final dwell (s)
    and how many points the longer dwell superseded; nothing for other runs."""
    exc = session.excitation
    if exc.kind != ADAPTIVE_KIND:
        return {}
    rows = session.extra
    predicted = float(rows["predicted_nrmse"][-1]) if rows is not None and rows.size else float("inf")
    target = float(exc.extra.get("target_nrmse", float("nan")))
    out = {"target_nrmse": target, "predicted_nrmse": predicted, "target_reached": bool(predicted <= target),
           "rig_time_cap_s": exc.extra.get("rig_time_cap_s")}
    if "first_dwell_s" in exc.extra and rows is not None and rows.size:
        out.update(first_dwell_s=exc.extra["first_dwell_s"],
                   final_dwell_s=session.final_dwell_s,
                   superseded_points=int(session.superseded.sum()))
    return out
