"""The drift monitor against the diagnosis: does the drift the diagnosis infers from the check
residual agree with what the calibration points measured independently?

A FORC measurement records a calibration point before every curve: the
same field after the same saturation, so its moment should never change;
what it does is instrument drift, measured without any model.  The
diagnosis's ``baseline_drift`` candidate infers a drift of the output
from the check residual alone (a penalised spline of session time per
run).  Both are compared at the calibration times, each about its own
mean (an offset is absorbed by the model): their correlation, sizes and
the rms of their difference.  They *agree* when the correlation is at
least :data:`AGREE_CORRELATION` and the sizes are within a factor
:data:`AGREE_RATIO`; otherwise the report says which part differs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from identify.diagnosis import Diagnosis
from identify.diagnosis.candidates import drift_at

from .loading import Loaded

#: Smallest correlation of inferred and measured drift that counts as agreement.
AGREE_CORRELATION = 0.7
#: Largest ratio of their rms sizes (either way) that counts as agreement.
AGREE_RATIO = 2.0


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def drift_agreement(result: Diagnosis, loaded: Loaded) -> dict[str, Any] | None:
    """The comparison for the first check run that has calibration points (None when none has).

    Keys: ``run``, ``n`` calibration points, ``measured_rms``/``measured_range``
    (output unit, about the mean), ``drift_correction`` (what the session's
    outputs already had applied, or None), ``inferred_rms``,
    ``correlation``, ``rms_difference``, ``agreement`` (``agrees``,
    ``different shape``, ``different size``) and ``note``; the inferred
    entries are None when ``baseline_drift`` was not scored.
    """
    name = next((r.name for r in loaded.check if r.name in loaded.monitors and r.name in result.check_runs), None)
    if name is None:
        return None
    cal = loaded.monitors[name]
    t = np.asarray(cal.t_s, dtype=float)
    measured = np.asarray(cal.output, dtype=float)
    measured = measured - measured.mean()
    out: dict[str, Any] = {
        "run": name, "n": int(t.size), "measured_rms": _rms(measured),
        "measured_range": float(np.ptp(measured)) if t.size else float("nan"),
        "drift_correction": (cal.drift_correction or {}).get("mode") if cal.drift_correction else None,
        "inferred_rms": None, "correlation": None, "rms_difference": None, "agreement": None, "note": "",
    }
    score = result.score("baseline_drift")
    runs = (score.params.get("runs") or {}) if score is not None else {}
    if name not in runs or t.size < 3:
        out["note"] = ("baseline_drift was not scored on this run, nothing to compare" if t.size >= 3
                       else "fewer than 3 calibration points")
        return out
    inferred = drift_at(runs[name], t)
    inferred = inferred - inferred.mean()
    a, b = _rms(inferred), out["measured_rms"]
    corr = float(np.corrcoef(inferred, measured)[0, 1]) if a > 0 and b > 0 else float("nan")
    ratio = a / b if b > 0 else float("inf")
    if not np.isfinite(corr) or corr < AGREE_CORRELATION:
        agreement = "different shape"
    elif not (1 / AGREE_RATIO <= ratio <= AGREE_RATIO):
        agreement = "different size"
    else:
        agreement = "agrees"
    out.update(inferred_rms=a, correlation=corr, rms_difference=_rms(inferred - measured), agreement=agreement,
               note=f"inferred/measured rms ratio {ratio:.3g}")
    return out
