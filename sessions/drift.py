"""Drift correction from calibration points (as FORC processing tools do).

A FORC script measures the moment at the same field (``HCal``, after the
same saturation) before every curve, so those calibration points should
all be equal: what they change by over the run is instrument drift (the
pick-up coils' sensitivity with temperature, the sample's position).
The correction interpolates the calibration output linearly in time
(constant before the first and after the last point) and either

* ``scale``: multiplies each output by ``reference / calibration(t)``
  (a drifting sensitivity; FORCinel's choice), or
* ``offset``: subtracts ``calibration(t) - reference`` (a drifting
  baseline),

with ``reference`` the mean of the calibration outputs, so the corrected
outputs keep the run's average level.  Off by default; a session records
the correction it applied and keeps the outputs as measured beside the
corrected ones.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import DataFileError

#: The corrections :func:`correct_drift` knows.
DRIFT_MODES = ("scale", "offset")


def calibration_at(t_s: np.ndarray, cal_t_s: np.ndarray, cal_output: np.ndarray) -> np.ndarray:
    """The calibration output at times ``t_s`` ``(n,)``: linear in time, constant beyond the ends."""
    order = np.argsort(cal_t_s, kind="stable")
    return np.interp(t_s, cal_t_s[order], cal_output[order])


def correct_drift(
    t_s: np.ndarray, outputs: np.ndarray, cal_t_s: np.ndarray, cal_output: np.ndarray, mode: str
) -> tuple[np.ndarray, dict[str, Any]]:
    """Drift-corrected ``outputs`` ``(n,)`` (NaN stays NaN) and the record of the correction.

    ``cal_t_s``, ``cal_output`` ``(K,)``: the calibration points' times (s)
    and outputs.  ``mode``: ``"scale"`` or ``"offset"`` (module docstring).
    """
    if mode not in DRIFT_MODES:
        raise DataFileError(f"unknown drift correction {mode!r}; choose {' or '.join(DRIFT_MODES)}")
    cal_t_s, cal_output = np.asarray(cal_t_s, float), np.asarray(cal_output, float)
    if cal_t_s.size == 0:
        raise DataFileError("drift correction needs calibration points, and there are none")
    reference = float(np.mean(cal_output))
    at = calibration_at(np.asarray(t_s, float), cal_t_s, cal_output)
    if mode == "scale":
        if np.any(cal_output == 0) or np.any(np.sign(cal_output) != np.sign(reference)):
            raise DataFileError(
                "scale drift correction needs calibration outputs of one sign, away from zero; use offset"
            )
        corrected = outputs * (reference / at)
    else:
        corrected = outputs - (at - reference)
    record = {
        "mode": mode,
        "reference": reference,
        "interpolation": "linear in time, constant beyond the first and last calibration point",
        "n_points": int(cal_t_s.size),
        "calibration_range": float(np.ptp(cal_output)),
        "source": "/calibration",
    }
    return corrected, record
