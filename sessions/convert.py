"""CSV traces to sessions and back (``rig import`` / ``rig export``).

A CSV trace ``t_s,v_V,deflection_um`` holds measured points only, so an
imported session measures every point; its excitation is ``damped`` (with
or without the thermal point) when the inputs are exactly the damped
oscillation of the given grid, else ``imported``.  Exporting needs every
point measured (a CSV cannot hold an applied-but-unmeasured point, and
dropping one would change the memory state of the rows after it) and the
rig's quantities (V in, um out), unless the caller asks for the measured
rows only.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from identify import Grid, damped_oscillation

from .csvtrace import Trace
from .csvtrace import dwell_from_time as dwell_from_time_of
from .errors import DataFileError
from .lock import held_by_other
from .reader import Session
from .records import CalibrationRecord, ExcitationRecord, Quantities
from .rewrite import fsync_directory
from .schema import SAMPLE_DTYPE, SampleFlag
from .writer import SessionWriter


def excitation_of_trace(
    trace: Trace, levels: int | None, v_min: float | None, v_max: float | None, extra: dict | None = None,
    dwell: dict | None = None,
) -> ExcitationRecord:
    """The excitation record of an imported trace (grid only when ``levels`` is given); ``dwell`` the
    record's dwell policy (default ``{"policy": "unknown"}``)."""
    kind, thermal = "imported", False
    grid = None
    if levels is not None:
        lo = float(np.min(trace.v_V)) if v_min is None else v_min
        hi = float(np.max(trace.v_V)) if v_max is None else v_max
        grid = Grid(levels, lo, hi)
        tol = 1e-9 * (grid.v_max - grid.v_min)
        for with_point in (True, False):
            design = damped_oscillation(grid, with_point)
            if design.shape == trace.v_V.shape and np.allclose(trace.v_V, design, rtol=0, atol=tol):
                kind, thermal = "damped", with_point
                break
    elif v_min is not None or v_max is not None:
        raise DataFileError("--v-min/--v-max describe a grid: give --levels too")
    return ExcitationRecord(
        kind=kind,
        inputs=trace.v_V,
        levels=None if grid is None else grid.levels,
        v_min=None if grid is None else grid.v_min,
        v_max=None if grid is None else grid.v_max,
        thermal_term=thermal,
        dwell=dwell or {"policy": "unknown"},
        extra=dict(extra or {}),
    )


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def check_replaceable(path: Path, force: bool) -> None:
    """Refuse to replace an existing file unless ``force``, and never one being written."""
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory")
    if path.exists():
        if not force:
            raise DataFileError(f"{path}: already exists; use --force to replace it")
        if held_by_other(path):
            raise DataFileError(f"{path}: is being written by another process; it was not replaced")


def import_trace(
    trace: Trace,
    out: str | os.PathLike,
    *,
    levels: int | None = None,
    v_min: float | None = None,
    v_max: float | None = None,
    source: str | os.PathLike | None = None,
    operator: str = "",
    notes: str = "",
    force: bool = False,
    dwell_from_time: bool = False,
) -> None:
    """Write ``trace`` as a complete session at ``out`` (see :func:`write_new_session`).

    The dwells are the trace's ``dwell_s`` column when it has one; with ``dwell_from_time`` each reading's
    dwell is the time since the previous reading (:func:`~sessions.csvtrace.dwell_from_time`), an
    assumption the session records (``dwell.policy = "from_time"``); else they are unknown.
    """
    out = Path(out)
    check_replaceable(out, force)
    extra = source_record(source)
    where = str(source) if source is not None else "trace"
    if dwell_from_time and trace.dwell_s is not None:
        raise DataFileError(f"{where}: the trace records its dwells (column dwell_s); --dwell-from-time would "
                            "replace them: give one or the other")
    if dwell_from_time:
        dwell = dwell_from_time_of(trace, where)
        policy = {"policy": "from_time",
                  "assumption": "each reading's dwell is the time since the previous reading (rig import "
                                "--dwell-from-time); the first reading's, the time since the start"}
    elif trace.dwell_s is not None:
        dwell, policy = trace.dwell_s, {"policy": "recorded", "source": "the trace's dwell_s column"}
    else:
        dwell, policy = np.full(len(trace), np.nan), {"policy": "unknown"}
    excitation = excitation_of_trace(trace, levels, v_min, v_max, extra, policy)
    rows = np.zeros(len(trace), SAMPLE_DTYPE)
    rows["t_s"] = trace.t_s
    rows["input"] = trace.v_V
    rows["output"] = trace.deflection_um
    rows["raw"] = np.nan
    rows["dwell_s"] = dwell
    rows["measured"] = True
    rows["flags"] = SampleFlag.IMPORTED
    write_new_session(out, excitation, rows, operator=operator, notes=notes, force=force,
                      message=f"from {extra.get('source', 'a CSV trace')}")


def source_record(source: str | os.PathLike | None) -> dict:
    """``{"source": name, "source_sha256": digest}`` of an imported file (empty without one)."""
    if source is None:
        return {}
    src = Path(source)
    return {"source": src.name, "source_sha256": sha256_of(src)}


def write_new_session(
    out: Path,
    excitation: ExcitationRecord,
    rows: np.ndarray,
    *,
    quantities: Quantities | None = None,
    calibration: CalibrationRecord | None = None,
    operator: str = "",
    notes: str = "",
    force: bool = False,
    message: str = "",
) -> None:
    """Write a complete session (every row at once) at ``out``, status ``complete``.

    The session is built in a hidden file beside ``out`` and renamed over
    it only when complete, so an existing ``out`` (replaced only with
    ``force``, never while another process writes it) is never left
    half-written.
    """
    check_replaceable(out, force)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.import")
    tmp.unlink(missing_ok=True)
    try:
        writer = SessionWriter.create(tmp, excitation, quantities=quantities, calibration=calibration,
                                      operator=operator, notes=notes, fsync_interval_s=None)
        with writer:
            writer.extend(rows)
            writer.log("imported", message)
        check_replaceable(out, force)
        os.replace(tmp, out)
        fsync_directory(out.parent)
    finally:
        tmp.unlink(missing_ok=True)


def trace_of_session(session: Session, measured_only: bool = False) -> Trace:
    """The session's samples as a CSV trace (V in, um out)."""
    q = session.quantities
    if (q.input_unit, q.output_unit) != ("V", "um"):
        raise DataFileError(
            f"{session.path}: the session's quantities are {q.input_unit} in and {q.output_unit} out; "
            "the CSV trace format t_s,v_V,deflection_um holds V and um only"
        )
    rows = session.measured_rows
    unmeasured = session.n_samples - rows.size
    if unmeasured and not measured_only:
        raise DataFileError(
            f"{session.path}: {unmeasured} of {session.n_samples} points were applied but not measured, "
            "which a CSV trace cannot hold; export the measured rows only with --measured-only "
            "(their memory history is then lost)"
        )
    if rows.size == 0:
        raise DataFileError(f"{session.path}: no measured samples to export")
    s = session.samples[rows]
    for name, column in (("t_s", "t_s"), ("v_V", "input"), ("deflection_um", "output")):
        bad = np.flatnonzero(~np.isfinite(s[column]))
        if bad.size:  # a CSV trace holds finite numbers only: rig import would refuse the file written
            k = int(rows[bad[0]])
            raise DataFileError(f"{session.path}: row {k} has {column} {float(s[column][bad[0]])!r}, which a CSV trace cannot "
                                f"hold ({bad.size} such row(s)); nothing was written")
    return Trace(s["t_s"].copy(), s["input"].copy(), s["output"].copy(), s["dwell_s"].copy())
