"""``rig diagnose --discriminate PLAN.csv``: design the run that tells the diagnosis's rivals apart and write
it as a set-point file ``rig acquire --sequence PLAN.csv`` reads (``v_V,dwell_s``).

The design is :mod:`identify.diagnosis.discriminate`'s (pure); this module
picks the check run it is compared with, applies the limits the operator
gave (points, rig time), writes the file -- only when the plan separates
the rivals by :data:`~identify.diagnosis.discriminate.TARGET_SEPARATION`
noise levels -- and reports it in the JSON (``discriminate``) and in one
line of text.

``--discriminate-on CONFIG`` then acquires the plan on the rig (the command
does that, through ``rig acquire``'s own path); this module names the
session (:func:`checked_session`), the readings per point it is taken with
(:func:`readings_for`) and says in one line how the verdict changed
(:func:`verdict_summary`, :func:`changed`).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from identify.diagnosis import Diagnosis
from identify.diagnosis.discriminate import (TARGET_SEPARATION, Plan, design, noise_of, probe, request, rival_of,
                                             separation)
from identify.errors import IdentifyError
from identify.runs import Run

from ..errors import UserError

#: Limits on ``--points``.
MIN_POINTS, MAX_POINTS = 10, 10_000
#: ``--points`` when not given.
DEFAULT_POINTS = 360


@dataclass(frozen=True)
class PlanRequest:
    """What the operator asked for: where to write the plan and its limits (``rig_time_s`` None: the check
    run's rig time)."""

    path: Path
    points: int = DEFAULT_POINTS
    rig_time_s: float | None = None
    force: bool = False


def checked_request(path: Path | None, points: int | None, rig_time_s: float | None, force: bool,
                    ) -> PlanRequest | None:
    """The operator's ``--discriminate`` options, checked before any work: :class:`UserError` (exit 2) on a
    ``--points`` outside [10, 10000], a ``--rig-time`` not positive, or a plan path that exists without
    ``--force``; None when no plan is asked for (and then neither limit may be given)."""
    if path is None:
        if points is not None or rig_time_s is not None:
            raise UserError("--points and --rig-time limit a discriminating plan: give --discriminate PLAN.csv too")
        return None
    if points is not None and not MIN_POINTS <= points <= MAX_POINTS:
        raise UserError(f"--points {points}: a plan holds between {MIN_POINTS} and {MAX_POINTS} points")
    if rig_time_s is not None and not (np.isfinite(rig_time_s) and rig_time_s > 0):
        raise UserError(f"--rig-time {rig_time_s}: give a positive number of seconds")
    if path.exists() and not force:
        raise UserError(f"{path} exists; give --force to replace it, or another path")
    if path.exists() and path.is_dir():
        raise UserError(f"{path} is a directory; give a file path for the plan")
    if not path.parent.exists():
        raise UserError(f"{path.parent} does not exist; create it or give another path for the plan")
    return PlanRequest(path, DEFAULT_POINTS if points is None else points, rig_time_s, force)


def reference_check(checks: list[Run]) -> Run:
    """The check run a plan is compared with and its drifts are carried from: the longest in rig time."""
    return max(checks, key=lambda r: (float(np.sum(r.dwell_s)) if r.dwell_s is not None else 0.0, r.n))


def write_plan(plan: Plan, path: Path) -> None:
    """``v_V,dwell_s`` with a header line, atomically (a partial file is never left at ``path``)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write("v_V,dwell_s\n")
            for v, w in zip(plan.v_V, plan.dwell_s):
                fh.write(f"{v:.6g},{w:.6g}\n")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def discriminate(d: Diagnosis, checks: list[Run], asked: PlanRequest, seed: int = 0) -> dict[str, Any]:
    """Design and (when it separates the rivals) write the plan; the JSON's ``discriminate`` object.

    Keys: ``between`` (the rivals, best first), ``plan`` (the path written, or None), ``points``,
    ``rig_time_s``, ``predicted_separation`` ``{"plan", "check"}`` (noise levels: the smallest over the
    pairs of rivals, on the plan and on the existing check run), ``pairs`` (each pair's on the plan),
    ``noise_um`` (what one noise level is), ``design_s`` (wall time of the design) and ``reason`` (why no
    plan is written, or None).
    """
    want = request(d)
    out: dict[str, Any] = {"between": list(want.between), "plan": None, "points": 0, "rig_time_s": 0.0,
                           "predicted_separation": None, "reason": None}
    if not want.between:
        out["reason"] = want.reason
        return out
    sigma = noise_of(d)
    if sigma is None:
        out["reason"] = f"{want.reason}, but no noise level is known to count a separation in"
        return out
    check = reference_check(checks)
    lo, hi = d.grid.v_min, d.grid.v_max
    budget = asked.rig_time_s
    if budget is None and check.dwell_s is not None:
        budget = float(np.sum(check.dwell_s))
    try:
        rivals = [rival_of(d, n, check) for n in want.between]
        on_check = (separation(rivals, d.base.model, probe(check.inputs, check.dwell_s, check.readings,
                                                             initial_V=check.initial_V), sigma)[0]
                    if check.dwell_s is not None else None)
        start = time.perf_counter()
        plan = design(rivals, d.base.model, lo, hi, sigma, points=asked.points, rig_time_s=budget,
                      readings=check.readings, seed=seed)
        took = time.perf_counter() - start
    except IdentifyError as exc:
        out["reason"] = f"{want.reason}, but no plan can be designed: {exc}"
        return out
    out.update(points=plan.points, rig_time_s=plan.rig_time_s, noise_um=sigma, design_s=round(took, 2),
               predicted_separation={"plan": plan.separation, "check": on_check}, pairs=plan.pairs)
    if plan.separation < TARGET_SEPARATION:
        out["reason"] = (f"{want.reason}; the best plan within {asked.points} points and "
                         f"{'no limit on' if budget is None else f'{budget:.0f} s of'} rig time separates the "
                         f"rivals by {plan.separation:.2f} noise levels, short of {TARGET_SEPARATION:g} by "
                         f"{TARGET_SEPARATION - plan.separation:.2f}: not written (allow more with --points or "
                         f"--rig-time)")
        out["points"], out["rig_time_s"] = 0, 0.0
        return out
    write_plan(plan, asked.path)
    out["plan"] = str(asked.path)
    return out


def checked_session(asked: PlanRequest | None, config_path: Path | None) -> Path | None:
    """Where ``--discriminate-on CONFIG`` records the plan's session: the plan's path with the suffix
    ``.h5``, checked before any work (:class:`UserError`, exit 2): ``--discriminate`` must be given, the
    session must not be the plan itself, and an existing session is replaced only with ``--force`` (and
    never one another process is writing).  None when no run is asked for."""
    if config_path is None:
        return None
    if asked is None:
        raise UserError("--discriminate-on runs the discriminating plan on the rig: give --discriminate PLAN.csv too")
    session = asked.path.with_suffix(".h5")
    if session == asked.path:
        raise UserError(f"--discriminate {asked.path}: the plan is a CSV file (PLAN.csv); its session "
                        f"would be the plan itself")
    if session.is_dir():
        raise UserError(f"{session} is a directory; the session of the discriminating run goes there")
    if session.exists() or session.is_symlink():
        if not asked.force:
            raise UserError(f"{session} exists (the session --discriminate-on records); give --force to "
                            f"replace it, or another plan path")
        from sessions import DataFileError, read_session

        try:
            alive = read_session(session).writer_alive()
        except DataFileError:
            alive = False
        if alive:
            raise UserError(f"{session}: another process is writing this session now; it is not replaced")
    return session


def readings_for(checks: list[Run]) -> int | None:
    """The readings averaged per point of the check run the plan was compared with (None: not known)."""
    return reference_check(checks).readings


def verdict_summary(verdict: dict[str, Any]) -> str:
    """A ``--json`` verdict in a few words: ``explained: creep``, ``ambiguous (creep, baseline_drift)``,
    ``unexplained (best partial: creep)``, ``no_gap``, ``cannot_tell``."""
    status = verdict["status"]
    if status == "explained":
        return f"explained: {' + '.join(verdict.get('effects') or [verdict.get('effect')])}"
    if status == "ambiguous":
        return f"ambiguous ({', '.join(verdict.get('rivals') or verdict.get('contenders') or [])})"
    if status == "unexplained" and verdict.get("contenders"):
        return f"unexplained (best partial: {verdict['contenders'][0]})"
    return str(status)


def changed(before: dict[str, Any], after: dict[str, Any]) -> str:
    """How the verdict changed, in one line: ``ambiguous (creep, baseline_drift) -> explained: creep``
    (``(unchanged)`` appended when it did not)."""
    a, b = verdict_summary(before), verdict_summary(after)
    return f"{a} -> {b}" + (" (unchanged)" if a == b else "")


def to_line(obj: dict[str, Any]) -> str:
    """The text's one line about the discriminating run."""
    if obj["plan"] is None:
        return f"discriminate: no plan written: {obj['reason']}"
    sep = obj["predicted_separation"]
    on_check = "" if sep["check"] is None else f" (against {sep['check']:.1f} on the check run)"
    return (f"discriminate: wrote {obj['plan']} ({obj['points']} points, {obj['rig_time_s']:.0f} s of rig time) "
            f"to tell apart {' and '.join([', '.join(obj['between'][:-1]), obj['between'][-1]])}: predicted separation {sep['plan']:.1f} noise "
            f"levels{on_check}; "
            + (f"acquiring it on {obj['on']} into {obj['session']}" if obj.get("on") else
               f"acquire it with rig acquire --sequence {obj['plan']} and diagnose again with both check runs"))
