"""A tracking run: its plan, its set-point source (new or resumed), and what it achieved.

The plan of a tracking run is an ordinary acquisition plan -- every point
measured and dwelt at -- whose planned inputs are the feed-forward inverse
of the targets from negative saturation (what ``rig invert`` writes), and
whose record keeps the targets (``/excitation/target``), the model
(``/models/NAME``, stored as the run starts) and the feedback law
(``extra.track``).  The sequencer then takes each set-point from
:class:`~rig.tracking.inverted_setpoints.TrackingSetpoints` instead of the plan; with
``--feedback none`` the two agree point for point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from identify import IdentifyError
from identify.inverse import Inverter, LinearInverse, invert, make_feedback
from sessions import ExcitationRecord, Session
from sessions.targets import Targets

from ..acquisition import DwellSettings, FixedDwell, Transit
from .inverted_setpoints import TrackingSetpoints
from .source import ModelSource

#: The excitation kind of a tracking run.
KIND = "track"
#: A run tracks "far beyond its model" when its RMSE exceeds this many times the model's own fit RMSE and
#: this fraction of the targets' range (a wrong model: a flipped sign, another actuator, another unit).
FAR_BEYOND, FAR_NRMSE = 10.0, 0.1


@dataclass(frozen=True)
class TrackPlan:
    """A new tracking run: its ``record`` (excitation with targets), ``settings`` (dwells), the ``source``
    model, the ``domain`` (V) the set-points keep to and the feed-forward plan's ``unreachable`` count."""

    record: ExcitationRecord
    settings: DwellSettings
    source: ModelSource
    domain: tuple[float, float]
    unreachable: int


def plan_track(source: ModelSource, targets: Targets, feedback: str, domain: tuple[float, float], *,
               dwell_s: float | None, saturate_s: float, readings: int, target_file: dict) -> TrackPlan:
    """The plan of a new tracking run (checks the feedback law against the targets; nothing is applied)."""
    dwell = targets.dwell_s if dwell_s is None else np.full(len(targets), float(dwell_s))
    law = make_feedback(feedback, targets.target_um)
    t_read = np.cumsum(dwell)
    ff = invert(source.model, targets.target_um, t_read, dwell, domain=domain, run_name="plan")
    settings = DwellSettings(FixedDwell(saturate_s), Transit(0.0), readings, tuple(float(d) for d in dwell))
    g = source.model.grid
    extra = {"track": {"source": str(source.path), "source_kind": source.kind, "model": source.record.name,
                       "method": source.record.method, "effects": [e.name for e in source.model.effects],
                       "domain_V": list(domain), **law.describe(), "target_file": target_file,
                       "planned_unreachable": ff.n_unreachable}}
    record = ExcitationRecord(kind=KIND, inputs=ff.voltages, measure=np.ones(len(targets), bool), levels=g.levels,
                              v_min=g.v_min, v_max=g.v_max, dwell=settings.describe(), extra=extra,
                              targets=targets.target_um)
    return TrackPlan(record, settings, source, domain, ff.n_unreachable)


def track_settings(session: Session) -> dict:
    """``extra.track`` of a tracking session (the model, the feedback law, the domain)."""
    track = session.excitation.extra.get("track")
    if not isinstance(track, dict) or session.excitation.targets is None:
        raise IdentifyError(f"{session.path}: not a tracking run (rig track writes one)")
    return track


def setpoints_for(session_or_plan, model, run_name: str) -> TrackingSetpoints:
    """The set-point source of a run: a new plan's, or (a :class:`Session`) an interrupted run's, its state
    rebuilt from the points it recorded."""
    if isinstance(session_or_plan, TrackPlan):
        rec = session_or_plan.record
        law = make_feedback(rec.extra["track"]["feedback"], rec.targets, rec.extra["track"])
        return TrackingSetpoints(model, rec.targets, law, session_or_plan.domain, run_name)
    s: Session = session_or_plan
    track = track_settings(s)
    law = make_feedback(track["feedback"], s.excitation.targets, track)
    src = TrackingSetpoints(model, s.excitation.targets, law, tuple(track["domain_V"]), run_name)
    ex = s.extra
    src.replay(s.inputs, s.t_s, s.samples["dwell_s"], s.outputs, ex["command"], ex["reachable"])
    return src


def summary(session: Session, model) -> dict:
    """What a tracking run achieved, measured against its targets (the ``rig track --json`` object)."""
    track = track_settings(session)
    n_applied = session.n_samples
    y = session.excitation.targets[:n_applied]
    measured = session.outputs
    ok = np.isfinite(measured)
    err = measured[ok] - y[ok]
    n = int(ok.sum())
    rmse = float(np.sqrt(np.mean(err ** 2))) if n else math.nan
    span = float(np.ptp(y[ok])) if n else 0.0
    ex = session.extra
    predicted = ex["predicted"] if ex is not None else np.full(n_applied, np.nan)
    model_err = measured[ok] - predicted[ok]
    out = {
        "n": n,
        "rmse_um": rmse,
        "max_abs_um": float(np.max(np.abs(err))) if n else math.nan,
        "nrmse": rmse / span if span > 0 else math.nan,
        "unreachable": int(np.count_nonzero(~ex["reachable"])) if ex is not None else 0,
        "feedback": track["feedback"],
        "baseline": {"linear_inverse_rmse_um": linear_baseline(session, model, tuple(track["domain_V"]))},
        "session": str(session.path),
        "status": session.status.value,
        "n_points": session.excitation.n_points,
        "model": track["model"],
        "source": track["source"],
        "effects": track.get("effects", []),
        "model_rmse_um": float(np.sqrt(np.mean(model_err ** 2))) if n else math.nan,
        "target_range_um": span,
        "rig_time_s": float(session.t_s[-1]) if n_applied else 0.0,
    }
    fitted = session.models.get(track["model"])
    out["model_fit_rmse_um"] = fitted.metrics.get("rmse") if fitted is not None else None
    out["warning"] = tracking_warning(out)
    period = track.get("period")
    if period:
        reps = []
        for start in range(0, n_applied, int(period)):
            sl = slice(start, min(start + int(period), n_applied))
            e = (measured[sl] - y[sl])[np.isfinite(measured[sl])]
            reps.append(float(np.sqrt(np.mean(e ** 2))) if e.size else math.nan)
        out["repetitions_rmse_um"] = reps
    return out


def tracking_warning(result: dict) -> str | None:
    """Why a finished tracking run did not do what its model promised (None when it did): most targets
    unreachable, or an error far beyond the model's own (``FAR_BEYOND`` x its fit RMSE and ``FAR_NRMSE`` of
    the targets' range)."""
    n, rmse, fit = result["n"], result["rmse_um"], result.get("model_fit_rmse_um")
    why = []
    if n and result["unreachable"] > n / 2:
        why.append(f"{result['unreachable']} of {n} targets were unreachable from the memory states the run reached")
    far = math.isfinite(rmse) and result["nrmse"] > FAR_NRMSE and (fit is None or rmse > FAR_BEYOND * fit)
    if far:
        model = (f", far beyond {FAR_BEYOND:g} x the model's own fit error ({fit:.3g} um)" if fit is not None
                 else "")
        why.append(f"the tracking error is rmse {rmse:.3g} um ({100 * result['nrmse']:.0f}% of the targets' "
                   f"range){model}")
    if not why:
        return None
    return ("; ".join(why) + ": the model does not describe this actuator (a wrong model, a flipped sign, another "
            "device or unit?) -- check it with rig validate on a fresh run before tracking with it")


def linear_baseline(session: Session, model, domain: tuple[float, float]) -> float:
    """The RMSE (um) the linear inverse of the major loop would have given on this run's targets, by the
    model (at the run's own times and dwells): the baseline a practitioner starts from, predicted, not
    measured."""
    n = session.n_samples
    if n == 0:
        return math.nan
    y = session.excitation.targets[:n]
    v = LinearInverse.of_model(model, domain).voltages(y)
    inv = Inverter(model, domain=domain, run_name=session.path.stem)
    t, d = session.t_s, session.samples["dwell_s"]
    pred = np.array([inv.apply(float(v[k]), float(t[k]), float(d[k])) for k in range(n)])
    return float(np.sqrt(np.mean((pred - y) ** 2)))
