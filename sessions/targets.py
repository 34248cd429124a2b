"""Target files (``t_s,target_um``) for ``rig invert`` and ``rig track``, and the set-point file ``rig invert`` writes.

A target file has one header line, exactly ``t_s,target_um``, then one row
per target: the time (s) at which the deflection should be read, and the
deflection (um) it should have.  Every value must be a finite number, the
times must increase, and no value may be missing: a target with a gap
(an empty cell, a blank line between rows) is refused, naming the line,
never filled in.

The set-point file written by ``rig invert`` has the header
``t_s,v_V,target_um,predicted_um,reachable``: each target's time, the
heater voltage for it, the target, the model's prediction there and
whether the target was reachable (``1``/``0``).
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .csvtrace import read_with_header
from .errors import DataFileError
from .textfiles import finite_number

HEADER = ("t_s", "target_um")
SETPOINT_HEADER = ("t_s", "v_V", "target_um", "predicted_um", "reachable")


@dataclass(frozen=True)
class Targets:
    """A target sequence: ``t_s`` (s, increasing) and ``target_um`` (um), both ``(n,)``; ``lines`` the line of
    the file each target was read from (None when not read from a file), for messages."""

    t_s: np.ndarray
    target_um: np.ndarray
    lines: tuple[int, ...] | None = None

    def where(self, k: int) -> str:
        """Target ``k`` as a person finds it: the file line it is on, else its 1-based number."""
        return f"line {self.lines[k]}" if self.lines is not None else f"target {k + 1}"

    def __len__(self) -> int:
        return int(self.target_um.size)

    @property
    def dwell_s(self) -> np.ndarray:
        """``(n,)``: the time from each target's set-point to its reading (s) -- the step from the previous
        target's time; the first target waits as long as the second (or its own time when alone)."""
        t = self.t_s
        if t.size == 1:
            return np.array([max(float(t[0]), 0.0)])
        d = np.diff(t)
        return np.concatenate([[d[0]], d])


def read_targets(path: str | os.PathLike) -> Targets:
    """Read a target file; :class:`DataFileError` naming the line and the problem otherwise."""
    path = Path(path)
    rows = read_with_header(path, HEADER)
    while len(rows) > 1 and not any(c.strip() for c in rows[-1]):
        rows.pop()  # blank lines at the end of the file
    t, y, lines = [], [], []
    for lineno, row in enumerate(rows[1:], start=2):
        where = f"{path}: line {lineno}"
        if not any(c.strip() for c in row):
            raise DataFileError(f"{where}: a blank line between targets (a gap in the target); every target "
                                "needs its row")
        if len(row) != 2:
            raise DataFileError(f"{where}: expected 2 values (t_s,target_um), got {len(row)}")
        for name, cell in zip(HEADER, row):
            if not cell.strip():
                raise DataFileError(f"{where}: {name} is empty (a gap in the target); nothing is filled in")
        t.append(finite_number(row[0].strip(), where, "t_s"))
        y.append(finite_number(row[1].strip(), where, "target_um"))
        lines.append(lineno)
        if len(t) > 1 and t[-1] <= t[-2]:
            raise DataFileError(f"{where}: t_s {t[-1]:g} does not increase (the row before has {t[-2]:g})")
    if not t:
        raise DataFileError(f"{path}: no targets after the header")
    return Targets(np.asarray(t, dtype=float), np.asarray(y, dtype=float), tuple(lines))


def write_targets(path: str | os.PathLike, targets: Targets) -> None:
    """Write a target file (full float precision)."""
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(HEADER)
        for t, y in zip(targets.t_s, targets.target_um):
            w.writerow([repr(float(t)), repr(float(y))])


def write_setpoints(path: str | os.PathLike, t_s: np.ndarray, v_V: np.ndarray, target_um: np.ndarray,
                    predicted_um: np.ndarray, reachable: np.ndarray) -> None:
    """Write ``rig invert``'s set-point file beside ``path`` and rename it over ``path`` once complete."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.partial")
    try:
        with tmp.open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(SETPOINT_HEADER)
            for row in zip(t_s, v_V, target_um, predicted_um, reachable):
                w.writerow([repr(float(row[0])), repr(float(row[1])), repr(float(row[2])), repr(float(row[3])),
                            int(bool(row[4]))])
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise DataFileError(f"{path}: cannot write the set-points ({exc.strerror})") from None
