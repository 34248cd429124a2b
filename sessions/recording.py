"""A recorded input/output sequence as fitting needs it, from a CSV trace or a session."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from identify import Grid

from .csvtrace import read_trace
from .errors import DataFileError
from .formats import HDF5_SUFFIXES, FileKind, detect, not_a_run
from .reader import Session, read_session


@dataclass(frozen=True, eq=False)
class Recording:
    """Every applied input and the measured outputs, shape ``(n,)`` each.

    ``outputs`` is NaN at points that were applied but not measured; the
    applied inputs still set the memory state of every later point.
    ``grid`` is the grid the excitation was built on, when recorded.
    ``session`` is the session read, or ``None`` for a CSV trace.
    ``t_s`` ``(n,)`` is the time of every point (s since the start).
    ``curves`` ``(n,)`` numbers the curve of every point (-1: none) when
    the run is made of curves (an imported FORC measurement), else ``None``.
    ``dwell_s`` ``(n,)`` (a CSV trace with a ``dwell_s`` column) the time from each set-point change to
    its reading (s); a session's are in its samples.
    """

    path: Path
    inputs: np.ndarray
    outputs: np.ndarray
    grid: Grid | None
    input_unit: str
    output_unit: str
    session: Session | None = None
    t_s: np.ndarray | None = None
    curves: np.ndarray | None = None
    dwell_s: np.ndarray | None = None

    @property
    def measured_rows(self) -> np.ndarray:
        return np.flatnonzero(np.isfinite(self.outputs))


def load_recording(path: str | os.PathLike) -> Recording:
    """Read ``path`` as a session if it is an HDF5 file, as a CSV trace if it is text.

    The format is judged by content (:func:`sessions.formats.detect`): a
    file that is neither is refused saying what it is.
    """
    path = Path(path)
    kind = detect(path)
    if kind not in (FileKind.HDF5, FileKind.TEXT, FileKind.EMPTY):
        raise DataFileError(not_a_run(path, kind))
    if kind is not FileKind.HDF5:
        try:
            trace = read_trace(path)
        except DataFileError as exc:
            if path.suffix.lower() not in HDF5_SUFFIXES:
                raise
            why = str(exc).removeprefix(f"{path}: ")
            raise DataFileError(f"{path}: not an HDF5 file, so not a session although named like one, "
                                f"and not a CSV trace either ({why})") from None
        return Recording(path, trace.v_V, trace.deflection_um, None, "V", "um", t_s=trace.t_s, dwell_s=trace.dwell_s)
    session = read_session(path)
    if session.n_samples == 0:
        raise DataFileError(f"{path}: the session holds no samples")
    if not np.any(session.measured):
        raise DataFileError(f"{path}: none of the session's {session.n_samples} points was measured")
    q = session.quantities
    return Recording(path, session.inputs, session.outputs, session.grid, q.input_unit, q.output_unit, session,
                     session.t_s, session.curves)
