"""The excitation a run applies: ``--sequence damped | random | FILE.csv``.

* ``damped`` -- the damped oscillation of the grid, with the thermal-term
  point unless told otherwise (:meth:`identify.Excitation.damped`);
* ``random`` -- a random validation input of ``points`` values on the grid
  (:meth:`identify.Excitation.random`, seeded);
* ``check`` -- a check run for ``rig diagnose``: ``points`` set-points with
  random reversals, several step sizes and per-point dwells, and repeated
  set-points (:func:`identify.diagnosis.check_design`, seeded);
* ``damped+check`` -- an identification run for a model with effects
  (``rig identify --with``): the damped oscillation (with the thermal
  point), then, without returning to saturation, a check design of
  ``points`` points with its own dwells.  The damped oscillation alone is
  square -- it has exactly as many points as equation (22) has parameters --
  so it cannot tell an effect from the density; the check part adds the
  redundancy and the variety (steps, dwells) that can;
* ``FILE.csv`` -- set-points from a CSV file with a header line naming a
  ``v_V`` column (other columns are ignored, so a recorded trace
  ``t_s,v_V,deflection_um`` replays its inputs).  An optional ``dwell_s``
  column gives every point its own fixed dwell (a check run's several
  dwell times, see :func:`sequence_dwells`).  The grid is recorded
  only when ``levels`` is given (range: the options, else the data's); a
  file holding exactly the damped oscillation of that grid is recorded as
  ``damped``, as ``rig import`` does.

The grid defaults to L = 30 levels on the heater's window (from 0 V).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import dataclasses
from pathlib import Path

import numpy as np

from drivers.protocols import VoltageWindow
from identify import Excitation, Grid
from sessions import DataFileError, ExcitationRecord
from sessions.convert import excitation_of_trace, sha256_of
from sessions.csvtrace import Trace, read_csv_rows

if TYPE_CHECKING:
    from identify.diagnosis.check_run_design import CheckDesign

#: The paper's discretisation (section 5.2).
DEFAULT_LEVELS = 30
#: Length of a random validation input when not given.
DEFAULT_RANDOM_POINTS = 200
#: Length of a check run for the gap diagnosis when not given.
DEFAULT_CHECK_POINTS = 200
#: The column of a set-point file that holds the heater voltages.
SETPOINT_COLUMN = "v_V"
#: The optional column of a set-point file that holds each point's dwell time (s).
DWELL_COLUMN = "dwell_s"


def read_setpoint_file(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """The ``v_V`` column (V) of a CSV set-point file and, when present, its ``dwell_s`` column (s).

    Both have shape ``(n,)``; a dwell must be a finite number of seconds
    >= 0.  Problems raise :class:`DataFileError` naming the line.
    """
    path = Path(path)
    rows = read_csv_rows(path)
    if not rows:
        raise DataFileError(f"{path}: empty file, expected a header line with a {SETPOINT_COLUMN} column")
    header = [c.strip() for c in rows[0]]
    if SETPOINT_COLUMN not in header:
        raise DataFileError(
            f"{path}: line 1: no {SETPOINT_COLUMN} column in the header {','.join(header)} "
            f"(a set-point file needs a header line naming a {SETPOINT_COLUMN} column)"
        )
    columns = [(SETPOINT_COLUMN, header.index(SETPOINT_COLUMN))]
    if DWELL_COLUMN in header:
        columns.append((DWELL_COLUMN, header.index(DWELL_COLUMN)))
    values: dict[str, list[float]] = {name: [] for name, _ in columns}
    for lineno, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise DataFileError(f"{path}: line {lineno}: expected {len(header)} values, got {len(row)}")
        for name, col in columns:
            cell = row[col].strip()
            try:
                x = float(cell)
            except ValueError:
                raise DataFileError(f"{path}: line {lineno}: {name} value {cell!r} is not a number") from None
            if not np.isfinite(x) or (name == DWELL_COLUMN and x < 0):
                what = "not finite" if not np.isfinite(x) else "negative"
                raise DataFileError(f"{path}: line {lineno}: {name} value {cell!r} is {what}")
            values[name].append(x)
    if not values[SETPOINT_COLUMN]:
        raise DataFileError(f"{path}: no set-points after the header")
    dwell = values.get(DWELL_COLUMN)
    return np.asarray(values[SETPOINT_COLUMN], dtype=float), None if dwell is None else np.asarray(dwell, dtype=float)


def read_setpoints(path: str | Path) -> np.ndarray:
    """The ``v_V`` column (V) of a CSV file, shape ``(n,)``; :class:`DataFileError` naming the line otherwise."""
    return read_setpoint_file(path)[0]


#: Seed offset of the check part of ``damped+check`` (so it differs from a check run of the same seed).
COMPOSITE_CHECK_SEED = 7919


def sequence_dwells(
    sequence: str,
    window: VoltageWindow | None = None,
    *,
    levels: int | None = None,
    v_min: float | None = None,
    v_max: float | None = None,
    points: int | None = None,
    seed: int | None = 0,
    thermal_term: bool = True,
    dwell: float | None = None,
    choices: tuple[float, ...] | None = None,
) -> np.ndarray | None:
    """Per-point dwell times (s): a check sequence's (same arguments as :func:`sequence_record`), a
    set-point file's ``dwell_s`` column, or ``damped+check``'s (``dwell`` s, then the check design's);
    None for the other sequences and files without one.

    ``choices`` (``--dwells``): every point of the damped or random part waits one of these, drawn at
    random with ``seed`` -- the varied dwells that tell a thermal lag's time constant from its size."""
    if sequence in ("damped", "random", "damped+check"):
        if window is None and sequence == "damped+check":
            raise ValueError("a check sequence needs the heater's window")
        n = (sequence_record(sequence.split("+")[0], window, levels=levels, v_min=v_min, v_max=v_max,
                             points=None if sequence != "random" else points, seed=seed,
                             thermal_term=thermal_term).n_points if (choices or sequence == "damped+check") else 0)
        if choices:
            first = np.random.default_rng(seed).choice(np.asarray(choices, dtype=float), size=n)
        elif sequence == "damped+check":
            first = np.full(n, 20.0 if dwell is None else float(dwell))
        else:
            return None
        if sequence != "damped+check":
            return first
        check = _check_design(window, levels, v_min, v_max, points, _composite_seed(seed))[1].dwell_s
        return np.concatenate([first, check])
    if choices:
        raise DataFileError("--dwells draws the dwells of a damped or random sequence; a check sequence "
                            "and a file with a dwell_s column have their own")
    if sequence == "check":
        if window is None:
            raise ValueError("a check sequence needs the heater's window")
        return _check_design(window, levels, v_min, v_max, points, seed)[1].dwell_s
    return read_setpoint_file(sequence)[1]


def _composite_seed(seed: int | None) -> int:
    return COMPOSITE_CHECK_SEED + (0 if seed is None else int(seed))


def default_grid(window: VoltageWindow, levels: int | None, v_min: float | None, v_max: float | None) -> Grid:
    """The grid of a generated sequence: L = 30 on the heater's window (from 0 V) unless given."""
    lo = max(window.min_V, 0.0) if v_min is None else v_min
    hi = window.max_V if v_max is None else v_max
    return Grid(DEFAULT_LEVELS if levels is None else levels, lo, hi)


def _check_design(window: VoltageWindow, levels, v_min, v_max, points, seed) -> tuple[Grid, CheckDesign]:
    # the diagnosis package (scipy.stats) is imported only when a check run is asked for
    from identify.diagnosis.check_run_design import check_design

    grid = default_grid(window, levels, v_min, v_max)
    n = DEFAULT_CHECK_POINTS if points is None else points
    return grid, check_design(grid.v_min, grid.v_max, n, seed=seed)


def sequence_record(
    sequence: str,
    window: VoltageWindow,
    *,
    levels: int | None = None,
    v_min: float | None = None,
    v_max: float | None = None,
    points: int | None = None,
    seed: int | None = 0,
    thermal_term: bool = True,
) -> ExcitationRecord:
    """The excitation named by ``sequence`` (measure plan and dwell not yet set)."""
    if points is not None and sequence not in ("random", "check", "damped+check"):
        raise DataFileError("--points sets the length of a random or check sequence: use it with --sequence "
                            "random, check or damped+check")
    if sequence == "damped+check":
        grid = default_grid(window, levels, v_min, v_max)
        damped = Excitation.damped(grid, thermal_term)
        _, design = _check_design(window, levels, v_min, v_max, points, _composite_seed(seed))
        return ExcitationRecord(kind="damped+check", inputs=np.concatenate([damped.inputs, design.inputs]),
                                levels=grid.levels, v_min=grid.v_min, v_max=grid.v_max, thermal_term=thermal_term,
                                seed=seed, extra={"damped_points": int(damped.inputs.size),
                                                  "check_points": int(design.inputs.size),
                                                  "dwell_choices_s": list(_dwell_choices())})
    if sequence == "damped":
        return ExcitationRecord.from_excitation(Excitation.damped(default_grid(window, levels, v_min, v_max), thermal_term))
    if sequence == "random":
        n = DEFAULT_RANDOM_POINTS if points is None else points
        return ExcitationRecord.from_excitation(Excitation.random(default_grid(window, levels, v_min, v_max), n, seed))
    if sequence == "check":
        grid, design = _check_design(window, levels, v_min, v_max, points, seed)
        return ExcitationRecord(kind="check", inputs=design.inputs, levels=grid.levels, v_min=grid.v_min,
                                v_max=grid.v_max, seed=seed, extra={"dwell_choices_s": list(_dwell_choices())})
    path = Path(sequence)
    if path.suffix.lower() != ".csv" and not path.exists():
        raise DataFileError(f"--sequence {sequence!r}: expected damped, random, check, damped+check or a CSV file "
                            "of set-points")
    v = read_setpoints(path)
    zeros = np.zeros_like(v)
    record = excitation_of_trace(Trace(zeros, v, zeros), levels, v_min, v_max,
                                 {"source": path.name, "source_sha256": sha256_of(path)})
    return dataclasses.replace(record, kind="file" if record.kind == "imported" else record.kind)


def _dwell_choices() -> tuple[float, ...]:
    from identify.diagnosis.check_run_design import DWELLS_S

    return DWELLS_S
