"""The session file layout (HDF5), version :data:`SCHEMA_VERSION`.

The full description, with the reasons behind it, is ``docs/sessions.md``;
this module holds the names and types that the writer and the reader share.

In short::

    /                   attrs: format, schema_version, software_version, created_at,
                               operator, notes, rig_config (JSON), driver (JSON),
                               input_quantity, input_unit, output_quantity,
                               output_unit, raw_quantity, raw_unit,
                               identify_recipe (JSON, optional: how to identify the session)
    /samples            one row per applied point, appended and flushed one at a time
                        (SAMPLE_DTYPE; row k is point k of the excitation)
    /log                the session's events (EVENT_DTYPE); the status is the last
                        event's status (running, complete, aborted, failed)
    /excitation         attrs: kind, levels, v_min, v_max, thermal_term, seed,
                               dwell (JSON), extra (JSON)
    /excitation/inputs  (N,) the planned input sequence
    /excitation/measure (N,) bool, which points are planned to be measured
    /excitation/curve   (N,) int32, optional: the curve each point belongs to (-1: none)
    /calibration        optional table of drift-monitor measurements (CALIBRATION_DTYPE)
    /models/<name>      identified models (see :mod:`sessions.models`)

The status lives in ``/log`` rather than in an attribute because an HDF5
single-writer/multiple-reader (SWMR) writer may only write to existing
datasets: creating or changing attributes while readers follow the file is
outside what SWMR supports.
"""

from __future__ import annotations

import enum

import numpy as np

#: Value of the root attribute ``format`` that marks a file as a session.
FORMAT_NAME = "vo2rig-session"

#: Version of this layout.  Readers refuse files with a larger version;
#: additions that old readers can ignore (new attributes, columns or groups)
#: do not change it.
SCHEMA_VERSION = 1

#: HDF5 format bounds: the 1.10 format is the oldest that supports SWMR.
LIBVER = ("v110", "v110")

#: Sample rows per HDF5 chunk of ``/samples`` (each row is 54 bytes).
SAMPLE_CHUNK = 256

#: One row of ``/samples``: one applied point of the excitation.
SAMPLE_DTYPE = np.dtype(
    [
        ("index", "<i8"),  # point index in the excitation; -1 marks a row not yet written
        ("t_s", "<f8"),  # time since the start of the run (s)
        ("input", "<f8"),  # commanded input (input_unit; heater voltage in V)
        ("output", "<f8"),  # measured output (output_unit; deflection in um), NaN if not measured
        ("raw", "<f8"),  # raw sensor signal (raw_unit; PSD voltage in V), NaN if none
        ("dwell_s", "<f8"),  # time actually waited before measuring (s), NaN if unknown
        ("settled", "?"),  # the settle condition was met before measuring
        ("measured", "?"),  # the output was measured at this point
        ("flags", "<u4"),  # SampleFlag bits
    ]
)

#: The fill value of ``/samples``: what a reader sees in a row whose extent
#: reached the file before its data did.
SAMPLE_FILL = np.array((-1, np.nan, np.nan, np.nan, np.nan, np.nan, False, False, 0), dtype=SAMPLE_DTYPE)

#: The extra ``/samples`` columns of a tracking run (``rig track``): the output each point was meant to reach
#: (``target``), what the inverse was asked for after the feedback's correction (``command``), the model's
#: prediction at the commanded input (``predicted``), all in output_unit, and whether the command was
#: reachable from the memory state.  Readers that do not know them ignore them.
TRACKING_COLUMNS = np.dtype([("target", "<f8"), ("command", "<f8"), ("predicted", "<f8"), ("reachable", "?")])
#: Extra sample columns of a run to a target error (``rig acquire --target-nrmse``): the predicted check
#: nRMSE after the point, what the point was (0: chosen by design, 1: a random check point, 2: a replicate),
#: and the wait the run asked of it (s; NaN when the run does not set its dwell) -- a pause lengthens the
#: recorded ``dwell_s``, never this.
ADAPTIVE_COLUMNS = np.dtype([("predicted_nrmse", "<f8"), ("point_kind", "<i4"), ("asked_dwell_s", "<f8")])
#: Excitation kind of a run that decides its own length: its planned inputs are placeholders, its plan
#: its most points, and it is complete with fewer.
ADAPTIVE_KIND = "adaptive"


def samples_dtype(extra: np.dtype | None = None) -> np.dtype:
    """The ``/samples`` row: :data:`SAMPLE_DTYPE` followed by ``extra``'s columns (None: none)."""
    if extra is None or not extra.names:
        return SAMPLE_DTYPE
    clash = set(extra.names) & set(SAMPLE_DTYPE.names)
    if clash:
        raise ValueError(f"extra sample columns {sorted(clash)} clash with the standard ones")
    return np.dtype(SAMPLE_DTYPE.descr + extra.descr)


def samples_fill(dtype: np.dtype) -> np.ndarray:
    """The fill value of a ``/samples`` table of ``dtype``: :data:`SAMPLE_FILL`, extra floats NaN, the rest 0."""
    fill = np.zeros((), dtype)
    for name in dtype.names:
        if name in SAMPLE_DTYPE.names:
            fill[name] = SAMPLE_FILL[name]
        elif dtype[name].kind == "f":
            fill[name] = np.nan
    return fill


#: One row of ``/calibration``: a measurement at a fixed reference input taken
#: to monitor drift (a FORC protocol's calibration point before each curve).
CALIBRATION_DTYPE = np.dtype(
    [
        ("t_s", "<f8"),  # time since the start of the run (s)
        ("input", "<f8"),  # the input at which it was measured (input_unit)
        ("output", "<f8"),  # the output as measured, never corrected (output_unit)
        ("curve", "<i8"),  # the curve it precedes (-1: none)
        ("row", "<i8"),  # the /samples row of the applied point it was measured at (-1: none)
    ]
)

#: Length in bytes of the fixed-size text fields of ``/log`` (UTF-8).
STATUS_BYTES, EVENT_BYTES, MESSAGE_BYTES = 16, 32, 480

#: One row of ``/log``.  Fixed-size strings: variable-length data is not safe
#: for SWMR readers.
EVENT_DTYPE = np.dtype(
    [
        ("t_unix", "<f8"),  # wall-clock time of the event (s since 1970, UTC)
        ("n_samples", "<i8"),  # samples in the file when the event was logged
        ("status", f"S{STATUS_BYTES}"),  # the session status from this event on
        ("event", f"S{EVENT_BYTES}"),  # what happened (created, resumed, replayed, ...)
        ("message", f"S{MESSAGE_BYTES}"),  # free text (an error message, a reason)
    ]
)


class Status(str, enum.Enum):
    """The life cycle of a session."""

    RUNNING = "running"  # being written, or its writer died (see SessionFollower/lock)
    COMPLETE = "complete"  # every planned point was applied
    ABORTED = "aborted"  # stopped on request (Ctrl-C, abort)
    FAILED = "failed"  # stopped by an error (driver fault, ...)

    @property
    def final(self) -> bool:
        return self is not Status.RUNNING


class SampleFlag(enum.IntFlag):
    """Bits of the ``flags`` column; unknown bits are kept and ignored."""

    NONE = 0
    REVERSAL = 1  # the input changes direction at this point
    THERMAL_POINT = 2  # the extra point that identifies the thermal term
    DWELL_TIMEOUT = 4  # the settle wait reached its maximum without settling
    SENSOR_SATURATED = 8  # the sensor reading was at the end of its range
    AFTER_RESUME = 16  # first point after a resume (memory restored by replay)
    READ_RETRIED = 32  # a reading failed and was retried
    IMPORTED = 64  # imported from a file that did not record dwell or settling
    CALIBRATION = 128  # the calibration field of a FORC protocol; its measurement is in /calibration
    SATURATION = 256  # the input is held at the saturation field (a FORC protocol's HSat)
    RECONNECTED = 512  # the link to the instrument dropped and came back while this point was applied or measured


#: Default input and output quantities (the VO2 rig).
DEFAULT_QUANTITIES = {
    "input_quantity": "heater voltage",
    "input_unit": "V",
    "output_quantity": "deflection",
    "output_unit": "um",
    "raw_quantity": "PSD signal",
    "raw_unit": "V",
}


def software_version() -> str:
    """The installed vo2rig version (stored in every session and model)."""
    # imported here: importlib.metadata (with email) costs a command that only reads about 15 ms of start-up
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vo2rig")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"
