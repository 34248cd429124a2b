"""The CSV trace format ``t_s,v_V,deflection_um[,dwell_s]`` read by ``rig identify`` and ``rig import``.

One header line, exactly ``t_s,v_V,deflection_um`` or
``t_s,v_V,deflection_um,dwell_s`` (surrounding spaces are ignored), then one
row per sample: time since start (s), applied input (V), measured deflection
(um) and, optionally, the dwell (s): the time from the set-point change to
the reading, the meaning it has in ``rig acquire --sequence FILE.csv``.
Every value must be a finite number; a dwell must not be negative.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import DataFileError
from .formats import FileKind, detect
from .textfiles import finite_number, read_bytes

HEADER = ("t_s", "v_V", "deflection_um")
#: The optional fourth column.
DWELL = "dwell_s"


@dataclass(frozen=True)
class Trace:
    """A recorded input/output sequence; all arrays have shape ``(n,)``."""

    t_s: np.ndarray
    v_V: np.ndarray
    deflection_um: np.ndarray
    #: Seconds from each set-point change to its reading ``(n,)``, or None when the trace does not say.
    dwell_s: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = {len(self.t_s), len(self.v_V), len(self.deflection_um)}
        if self.dwell_s is not None:
            n.add(len(self.dwell_s))
        if len(n) != 1:
            raise DataFileError("trace columns have different lengths")

    def __len__(self) -> int:
        return len(self.v_V)


def read_csv_rows(path: Path) -> list[list[str]]:
    """Every row of a UTF-8 CSV file as strings; :class:`DataFileError` saying why it cannot be read
    (and, for a file of another kind, what it is: a session, a MicroMag file, binary data)."""
    kind = detect(path)
    if kind is FileKind.HDF5:
        raise DataFileError(f"{path}: an HDF5 file (a session?), not a CSV file")
    if kind is FileKind.MICROMAG:
        raise DataFileError(f"{path}: a MicroMag FORC data file, not a CSV file (rig import it with --format micromag)")
    if kind is FileKind.BINARY:
        raise DataFileError(f"{path}: binary data, not a text CSV file")
    raw = read_bytes(path, "a CSV file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DataFileError(f"{path}: not a UTF-8 text CSV file (byte {exc.start} is not UTF-8)") from None
    return list(csv.reader(io.StringIO(text, newline="")))


def read_with_header(path: Path, expected: tuple[str, ...]) -> list[list[str]]:
    """Every row of the CSV file at ``path`` (the header included), after checking that its header line is
    exactly ``expected``; :class:`DataFileError` naming what is wrong otherwise."""
    rows = read_csv_rows(path)
    if not rows:
        raise DataFileError(f"{path}: empty file, expected the header {','.join(expected)}")
    header = tuple(c.strip() for c in rows[0])
    if header != expected:
        missing = [c for c in expected if c not in header]
        what = f"missing column(s) {', '.join(missing)}" if missing else "wrong column order"
        raise DataFileError(
            f"{path}: line 1: expected the header {','.join(expected)}, got {','.join(header)} ({what})"
        )
    return rows


def _header_of(path: Path, rows: list[list[str]]) -> tuple[str, ...]:
    """The trace's header: :data:`HEADER`, with :data:`DWELL` after it when the file has that column."""
    first = tuple(c.strip() for c in rows[0]) if rows else ()
    return (*HEADER, DWELL) if first == (*HEADER, DWELL) else HEADER


def read_trace(path: str | os.PathLike) -> Trace:
    """Read a CSV trace; raises :class:`DataFileError` naming the problem and line."""
    path = Path(path)
    rows = read_csv_rows(path)
    header = _header_of(path, rows)
    rows = read_with_header(path, header)
    width = len(header)
    values = np.empty((len(rows) - 1, width))
    count = 0
    for lineno, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != width:
            what = f" (the header has a {DWELL} column: every row needs one)" if width > len(HEADER) else ""
            raise DataFileError(f"{path}: line {lineno}: expected {width} values, got {len(row)}{what}")
        for col, cell in enumerate(row):
            values[count, col] = finite_number(cell.strip(), f"{path}: line {lineno}", header[col])
        if width > len(HEADER) and values[count, 3] < 0:
            raise DataFileError(f"{path}: line {lineno}: {DWELL} is negative ({values[count, 3]:g}); a dwell is "
                                "the time from the set-point change to the reading")
        count += 1
    if count == 0:
        raise DataFileError(f"{path}: no data rows after the header")
    values = values[:count]
    return Trace(values[:, 0], values[:, 1], values[:, 2], values[:, 3].copy() if width > len(HEADER) else None)


def dwell_from_time(trace: Trace, path: str | os.PathLike = "trace") -> np.ndarray:
    """Each reading's dwell taken as the time since the previous reading (the first: since the start, when
    its time stamp is positive, else unknown), ``(n,)`` s; :class:`DataFileError` when the time stamps do
    not increase (the row named)."""
    t = np.asarray(trace.t_s, dtype=float)
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = int(bad[0])
        raise DataFileError(f"{path}: reading {k + 2}: the time stamp {t[k + 1]:g} s does not "
                            f"increase (the row before is at {t[k]:g} s); --dwell-from-time needs increasing time "
                            "stamps")
    first = t[0] if t.size and t[0] > 0 else np.nan
    return np.concatenate([[first], steps])


def write_trace(path: str | os.PathLike, trace: Trace) -> None:
    """Write a trace as CSV (full float precision), with its ``dwell_s`` column when it has every dwell."""
    dwell = trace.dwell_s
    with_dwell = dwell is not None and bool(np.all(np.isfinite(dwell)))
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow((*HEADER, DWELL) if with_dwell else HEADER)
        for i, (t, v, d) in enumerate(zip(trace.t_s, trace.v_V, trace.deflection_um)):
            w.writerow([repr(float(t)), repr(float(v)), repr(float(d))] + ([repr(float(dwell[i]))] if with_dwell else []))
