"""Recorded runs (sessions or CSV traces) as :class:`identify.diagnosis.Run`, with the checks a
diagnosis needs: units, grids, distinct files.

Problems that make a diagnosis meaningless (unreadable files, other units,
the same file to fit and to check, no grid, a partial session without
``--partial``: the rule of :mod:`rig.session_input`) are one-line errors;
problems it can live with (a partial session allowed, a check run recorded
on another grid, identification runs on different grids) become warnings
in the report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from identify import Grid
from identify.diagnosis import Run
from sessions import read_session
from sessions.recording import Recording

from ..errors import UserError
from ..session_input import open_run, partial_state, same_file


#: File names that promise a session (read as one, not as a CSV trace, even when broken).
HDF5_SUFFIXES = (".h5", ".hdf5", ".he5")


@dataclass
class Loaded:
    """The runs, the grid they are judged on, and what the user should know."""

    fit: list[Run]
    check: list[Run]
    grid: Grid
    warnings: list[str] = field(default_factory=list)


def run_of(data: Recording, name: str) -> Run:
    """A :class:`Run` from a recording: a session's time stamps and dwells, or a CSV trace's times."""
    s = data.session
    if s is None:
        return Run(name, data.inputs, data.outputs, data.t_s, np.full(data.inputs.size, np.nan))
    readings = s.excitation.dwell.get("readings")
    return Run(name, s.inputs, s.outputs, s.t_s, s.samples["dwell_s"],
               int(readings) if isinstance(readings, (int, float)) else None)


def _names(paths: list[Path]) -> list[str]:
    stems = [p.stem for p in paths]
    return [str(p) if stems.count(p.stem) > 1 else p.stem for p in paths]


def load_runs(fit_paths: list[Path], check_paths: list[Path], levels: int | None = None,
              v_min: float | None = None, v_max: float | None = None, *, allow_partial: bool = False) -> Loaded:
    """Read every file and decide the grid (the first identification session's, unless given)."""
    for f in fit_paths:
        for c in check_paths:
            if same_file(f, c):
                raise UserError(f"{c}: is also an identification run; the diagnosis judges only on "
                                "held-out runs, never on the data that was fitted")
    names = _names(list(fit_paths) + list(check_paths))
    warnings: list[str] = []
    recordings = []
    for path in list(fit_paths) + list(check_paths):
        if Path(path).suffix.lower() in HDF5_SUFFIXES:
            read_session(path)  # a session by its name: say what is wrong with it as a session
        data = open_run(path, allow_partial=allow_partial)
        if (data.input_unit, data.output_unit) != ("V", "um"):
            raise UserError(f"{path}: records {data.input_unit} in and {data.output_unit} out; "
                            "the diagnosis works in V and um")
        if data.session is not None and data.session.is_partial:
            warnings.append(f"{path}: partial session ({partial_state(data.session)}); using the points it holds")
        recordings.append(data)
    fit_data = recordings[: len(fit_paths)]
    grids = [d.grid for d in fit_data if d.grid is not None]
    if levels is not None:
        lo = v_min if v_min is not None else (grids[0].v_min if grids else float(np.min(fit_data[0].inputs)))
        hi = v_max if v_max is not None else (grids[0].v_max if grids else float(np.max(fit_data[0].inputs)))
        grid = Grid(levels, lo, hi)
    elif grids:
        g = grids[0]
        grid = Grid(g.levels, g.v_min if v_min is None else v_min, g.v_max if v_max is None else v_max)
    else:
        raise UserError(f"{fit_paths[0]}: records no grid; give --levels (and --v-min/--v-max)")
    for data in recordings:
        if data.grid is not None and data.grid != grid:
            role = "identification" if data in fit_data else "check"
            warnings.append(
                f"{data.path}: {role} run recorded on L={data.grid.levels} over [{data.grid.v_min:g}, "
                f"{data.grid.v_max:g}] V, not the diagnosis grid L={grid.levels} over [{grid.v_min:g}, "
                f"{grid.v_max:g}] V; it is used on the diagnosis grid"
            )
    runs = [run_of(d, n) for d, n in zip(recordings, names)]
    return Loaded(runs[: len(fit_paths)], runs[len(fit_paths):], grid, warnings)
