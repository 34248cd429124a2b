"""A MicroMag FORC file as a session (``rig import --format micromag``).

What the session holds (``docs/sessions.md``, *FORC sessions*):

* ``/samples``: every applied point of the protocol in order
  (:mod:`sessions.forc_protocol`): ``HSat`` and ``HCal`` before each curve
  (not measured; flags ``SATURATION``/``CALIBRATION``), then the curve
  (measured; its first point flagged ``REVERSAL``).  ``output`` is the
  moment (drift-corrected when asked), ``raw`` the moment as recorded.
* ``/excitation``: kind ``forc``, the inputs, the measured mask and
  ``curve``, the curve of every point (from 0, in file order; -1 for the
  saturation and calibration points); ``dwell`` the sweep settings;
  ``extra`` the source file, the header (every entry, by section) and
  how the times were made.
* ``/calibration``: the calibration points (time, field, moment as
  measured, curve, row), with ``drift_correction`` when one was applied.
* Quantities: ``applied field`` in the file's field unit (``T`` for Hybrid
  SI), ``magnetic moment`` in its moment unit (``A m^2``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from identify import Grid

from .convert import check_replaceable, source_record, write_new_session
from .drift import correct_drift
from .errors import DataFileError
from .forc_protocol import ProtocolHistory, SweepSettings, protocol_history
from .micromag import ForcFile
from .records import CalibrationRecord, ExcitationRecord, Quantities
from .schema import SAMPLE_DTYPE


def forc_quantities(forc: ForcFile) -> Quantities:
    """Applied field in, magnetic moment out, in the file's units."""
    h = forc.header
    return Quantities(
        input_quantity="applied field", input_unit=h.field_unit,
        output_quantity="magnetic moment", output_unit=h.moment_unit,
        raw_quantity="magnetic moment as recorded", raw_unit=h.moment_unit,
    )


def forc_grid(history: ProtocolHistory, levels: int | None, v_min: float | None, v_max: float | None) -> Grid | None:
    """The grid to record: only with ``levels``; the range defaults to the measured fields'."""
    if levels is None:
        if v_min is not None or v_max is not None:
            raise DataFileError("--v-min/--v-max describe a grid: give --levels too")
        return None
    measured = history.inputs[history.measured]
    return Grid(levels, float(measured.min()) if v_min is None else v_min,
                float(measured.max()) if v_max is None else v_max)


def import_forc(
    forc: ForcFile,
    out: str | os.PathLike,
    *,
    levels: int | None = None,
    v_min: float | None = None,
    v_max: float | None = None,
    drift: str | None = None,
    operator: str = "",
    notes: str = "",
    force: bool = False,
) -> ProtocolHistory:
    """Write ``forc`` as a complete session at ``out``; returns the protocol history written.

    ``drift`` (``"scale"``, ``"offset"`` or ``None``) corrects the outputs
    from the calibration points (:mod:`sessions.drift`).
    """
    out = Path(out)
    check_replaceable(out, force)
    settings = SweepSettings.from_header(forc.header, forc.path)
    history = protocol_history(forc, settings)
    grid = forc_grid(history, levels, v_min, v_max)
    cal_rows = history.calibration_rows
    cal_t = history.t_s[cal_rows]
    outputs, correction = history.outputs, None
    if drift is not None:
        outputs, correction = correct_drift(history.t_s, history.outputs, cal_t, history.calibration_moment, drift)
    rows = np.zeros(len(history), SAMPLE_DTYPE)
    rows["t_s"] = history.t_s
    rows["input"] = history.inputs
    rows["output"] = outputs
    rows["raw"] = history.outputs
    rows["dwell_s"] = np.nan
    rows["measured"] = history.measured
    rows["flags"] = history.flags
    excitation = ExcitationRecord(
        kind="forc",
        inputs=history.inputs,
        measure=history.measured,
        levels=None if grid is None else grid.levels,
        v_min=None if grid is None else grid.v_min,
        v_max=None if grid is None else grid.v_max,
        thermal_term=False,
        dwell={"policy": "forc script", **settings.to_dict()},
        extra=_extra(forc, history),
        curves=history.curve,
    )
    calibration = CalibrationRecord(
        t_s=cal_t, input=history.inputs[cal_rows], output=history.calibration_moment,
        curve=np.arange(cal_rows.size), row=cal_rows, drift_correction=correction,
    )
    message = f"from {forc.path.name}: {len(forc.curves)} curves, {forc.n_points} points"
    if correction is not None:
        message += f", drift-corrected ({drift})"
    write_new_session(out, excitation, rows, quantities=forc_quantities(forc), calibration=calibration,
                      operator=operator, notes=notes, force=force, message=message)
    return history


def _extra(forc: ForcFile, history: ProtocolHistory) -> dict[str, Any]:
    h = forc.header
    lengths = [len(c) for c in forc.curves]
    return {
        **source_record(forc.path),
        "format": "micromag",
        "header_style": h.style,
        "series": h.series,
        "measurement": h.kind,
        "measured_on": h.text("measured_on"),
        "description": h.text("description"),
        "n_curves": len(forc.curves),
        "curve_numbering": "from 0 in file order",
        "curve_points": {"min": min(lengths), "max": max(lengths)},
        "timing": history.timing,
        "header": h.as_dict(),
    }
