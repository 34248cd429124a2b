"""The input history of a FORC measurement, and when each point was measured.

A Preisach memory state depends on every input the sample saw, not only on
the measured ones.  Before each first-order reversal curve a MicroMag FORC
script drives the field up to ``HSat`` (positive saturation), down to
``HCal`` where it measures one calibration point, further down to the
curve's reversal field, and then measures the curve on the way back up.
:func:`protocol_history` writes that out as applied points, in order::

    for each curve k:   HSat (saturation; not measured)
                        HCal (calibration field; its measurement goes to
                              the drift monitor, not to the outputs)
                        the curve: its reversal field first, then upwards
                              (measured)

The ramps between these points are monotone, so the points in between
are wiped out of the memory and need not be listed (the wiping-out
property).  Inputs are the fields as the file records them (the measured
field, not the set-point); ``HSat``, which no file records, is the
header's value.

Times
-----
The files hold no time stamps.  :func:`sweep_times` rebuilds them from the
sweep settings: the field moves at ``SlewRate`` between points, waits
``PauseSat`` at saturation, ``PauseCal`` before the calibration point,
``PauseRvrsl`` (Series 0015: ``PauseNtl``) at the reversal field and, in
discrete sweep mode only, ``Pause after sweep increment`` before every
other point, and averages each measurement over ``Averaging time``; a
point's time is the middle of its averaging window, a transit point's the
moment the field arrives.  The header's ``Elapsed time`` is then matched:
what it holds beyond the settings' total is spread evenly over the
measured points as a per-point overhead (data transfer, settling), and a
total above the elapsed time is scaled down to it.  Both numbers are
recorded with the session.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import DataFileError
from .micromag import ForcFile, MicroMagHeader
from .schema import SampleFlag


@dataclass(frozen=True)
class SweepSettings:
    """The script settings that time a FORC measurement (field unit, s, field unit per s)."""

    h_sat: float
    h_cal: float
    averaging_s: float
    pause_saturation_s: float
    pause_calibration_s: float
    pause_reversal_s: float
    pause_increment_s: float
    slew_rate: float
    elapsed_s: float | None = None

    @classmethod
    def from_header(cls, header: MicroMagHeader, path: Path) -> "SweepSettings":
        """The settings a header gives; the ones the times need are required."""

        def need(key: str) -> float:
            return header.number(key, path, required=True)

        slew = need("slew_rate")
        if slew <= 0:
            raise DataFileError(f"{path}: line {header.entry('slew_rate').line}: SlewRate must be positive")
        for key in ("averaging_time", "pause_saturation", "pause_calibration", "pause_reversal"):
            if need(key) < 0:
                raise DataFileError(f"{path}: line {header.entry(key).line}: a negative time")
        mode = (header.text("sweep_mode") or "").lower()
        increment = header.number("pause_increment", path) if mode.startswith("discrete") else None
        elapsed = header.number("elapsed_time", path)
        return cls(
            h_sat=need("h_sat"),
            h_cal=need("h_cal"),
            averaging_s=need("averaging_time"),
            pause_saturation_s=need("pause_saturation"),
            pause_calibration_s=need("pause_calibration"),
            pause_reversal_s=need("pause_reversal"),
            pause_increment_s=max(increment or 0.0, 0.0),
            slew_rate=slew,
            elapsed_s=elapsed if elapsed is not None and elapsed > 0 else None,
        )

    def to_dict(self) -> dict[str, Any]:
        return dict(vars(self))


@dataclass(frozen=True, eq=False)
class ProtocolHistory:
    """Every applied point of a FORC measurement, in order; arrays ``(n,)``.

    ``inputs`` (field unit); ``outputs`` the moment where a curve point was
    measured, NaN elsewhere; ``curve`` the curve number (from 0, file
    order; -1 for the saturation and calibration points); ``flags``
    :class:`~sessions.SampleFlag` bits; ``line`` the file line of a
    measured point (0 for ``HSat``); ``t_s`` the times.
    ``calibration_rows`` ``(K,)`` are the rows of the calibration points and
    ``calibration_moment`` ``(K,)`` what was measured there.  ``timing``
    says how the times were made (see the module docstring).
    """

    inputs: np.ndarray
    outputs: np.ndarray
    curve: np.ndarray
    flags: np.ndarray
    line: np.ndarray
    t_s: np.ndarray
    calibration_rows: np.ndarray
    calibration_moment: np.ndarray
    timing: dict[str, Any]

    @property
    def measured(self) -> np.ndarray:
        return np.isfinite(self.outputs)

    def __len__(self) -> int:
        return int(self.inputs.size)


def protocol_history(forc: ForcFile, settings: SweepSettings) -> ProtocolHistory:
    """The applied points of ``forc`` (see the module docstring), with their times."""
    inputs, outputs, curve, flags, line = [], [], [], [], []
    cal_rows, cal_moment = [], []
    nan = np.nan
    row = 0
    for k, (cal, seg) in enumerate(zip(forc.calibration, forc.curves)):
        m = len(seg)
        inputs += [np.array([settings.h_sat, cal.field[0]]), seg.field]
        outputs += [np.array([nan, nan]), seg.moment]
        curve += [np.array([-1, -1]), np.full(m, k)]
        f = np.full(m, int(SampleFlag.IMPORTED), np.uint32)
        f[0] |= int(SampleFlag.REVERSAL)
        flags += [
            np.array([SampleFlag.IMPORTED | SampleFlag.SATURATION | SampleFlag.REVERSAL,
                      SampleFlag.IMPORTED | SampleFlag.CALIBRATION], np.uint32),
            f,
        ]
        line += [np.array([0, cal.line]), seg.line + np.arange(m)]
        cal_rows.append(row + 1)
        cal_moment.append(cal.moment[0])
        row += 2 + m
    cat = np.concatenate
    v, y, fl = cat(inputs), cat(outputs), cat(flags)
    t, timing = sweep_times(v, fl, settings)
    return ProtocolHistory(
        inputs=v, outputs=y, curve=cat(curve).astype(np.int64), flags=fl, line=cat(line).astype(np.int64),
        t_s=t, calibration_rows=np.array(cal_rows, np.int64), calibration_moment=np.array(cal_moment),
        timing=timing,
    )


def sweep_times(inputs: np.ndarray, flags: np.ndarray, s: SweepSettings) -> tuple[np.ndarray, dict[str, Any]]:
    """Times ``(n,)`` (s from the start of the script) of a FORC protocol's points, and how they were made.

    ``flags`` tells the kind of each point: saturation, calibration,
    reversal (the first point of a curve), else a curve point.  The field
    starts at 0.  See the module docstring for the rules.
    """
    sat = (flags & SampleFlag.SATURATION) != 0
    cal = (flags & SampleFlag.CALIBRATION) != 0
    first = ((flags & SampleFlag.REVERSAL) != 0) & ~sat
    measured = ~sat
    ramp = np.abs(np.diff(inputs, prepend=0.0)) / s.slew_rate
    pause = np.where(cal, s.pause_calibration_s, np.where(first, s.pause_reversal_s, s.pause_increment_s))
    pause = np.where(sat, 0.0, pause)
    averaging = np.where(measured, s.averaging_s, 0.0)
    after = np.where(sat, s.pause_saturation_s, 0.0)

    def times(overhead: float) -> tuple[np.ndarray, float]:
        duration = ramp + pause + averaging + after + np.where(measured, overhead, 0.0)
        end = np.cumsum(duration)
        start = end - duration
        t = start + ramp + pause + 0.5 * averaging
        return t, float(end[-1])

    t, nominal = times(0.0)
    n_measured = int(np.count_nonzero(measured))
    timing: dict[str, Any] = {"model": "sweep settings", "nominal_s": nominal, "elapsed_s": s.elapsed_s,
                              "overhead_per_point_s": 0.0, "scale": 1.0}
    if s.elapsed_s is not None and n_measured:
        if s.elapsed_s >= nominal:
            overhead = (s.elapsed_s - nominal) / n_measured
            t, _ = times(overhead)
            timing.update(model="sweep settings + per-point overhead matching the elapsed time",
                          overhead_per_point_s=overhead)
        else:
            scale = s.elapsed_s / nominal
            t = t * scale
            timing.update(model="sweep settings scaled to the elapsed time", scale=scale)
    return t, timing
