"""The CSV trace format ``t_s,v_V,deflection_um`` read by ``rig identify``.

One header line, exactly ``t_s,v_V,deflection_um`` (surrounding spaces are
ignored), then one row per sample: time since start (s), applied input (V),
measured deflection (um).  Every value must be a finite number.
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


@dataclass(frozen=True)
class Trace:
    """A recorded input/output sequence; all arrays have shape ``(n,)``."""

    t_s: np.ndarray
    v_V: np.ndarray
    deflection_um: np.ndarray

    def __post_init__(self) -> None:
        n = {len(self.t_s), len(self.v_V), len(self.deflection_um)}
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


def read_trace(path: str | os.PathLike) -> Trace:
    """Read a CSV trace; raises :class:`DataFileError` naming the problem and line."""
    path = Path(path)
    rows = read_with_header(path, HEADER)
    values = np.empty((len(rows) - 1, 3))
    count = 0
    for lineno, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != 3:
            raise DataFileError(f"{path}: line {lineno}: expected 3 values, got {len(row)}")
        for col, cell in enumerate(row):
            values[count, col] = finite_number(cell.strip(), f"{path}: line {lineno}", HEADER[col])
        count += 1
    if count == 0:
        raise DataFileError(f"{path}: no data rows after the header")
    values = values[:count]
    return Trace(values[:, 0], values[:, 1], values[:, 2])


def write_trace(path: str | os.PathLike, trace: Trace) -> None:
    """Write a trace as CSV (full float precision)."""
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(HEADER)
        for t, v, d in zip(trace.t_s, trace.v_V, trace.deflection_um):
            w.writerow([repr(float(t)), repr(float(v)), repr(float(d))])
