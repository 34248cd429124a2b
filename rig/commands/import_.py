"""``rig import``: turn a recorded trace or a measurement file into a session file."""

from __future__ import annotations

from pathlib import Path

import click

from sessions import DataFileError, SampleFlag, read_session, read_trace
from sessions.convert import import_trace
from sessions.drift import DRIFT_MODES
from sessions.forc_import import import_forc
from sessions.micromag import read_forc

from ..errors import UserError
from ..output import print_json

#: Formats ``rig import`` reads.
FORMATS = ("csv", "micromag")


def _refuse_replacing_an_acquisition(out: Path, force: bool) -> None:
    """``--force`` replaces an earlier import; a session holding acquired samples -- which rig acquire itself
    never replaces -- only when named with ``--replace-session``."""
    if not (force and out.is_file()):
        return
    try:
        session = read_session(out)
    except DataFileError:
        return  # not a readable session: --force decides, as for any file
    acquired = int((session.samples["flags"] & SampleFlag.IMPORTED == 0).sum())
    if acquired:
        raise UserError(f"{out}: holds {acquired} acquired sample(s) (rig acquire or rig track), which --force does "
                        f"not replace; nothing was written -- to replace it after all, name it: --replace-session {out}")


@click.command(name="import")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "-o", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Session file to write (HDF5).")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="csv", show_default=True,
              help="Format of FILE: csv is the trace t_s,v_V,deflection_um; micromag a MicroMag 2900/3900 "
                   "FORC data file (Series 0015 or 0016 header).")
@click.option("--levels", "-L", type=int, help="Record the grid: levels L (>= 1).")
@click.option("--v-min", type=float,
              help="Lower end of the grid (input unit); default: the smallest measured input.")
@click.option("--v-max", type=float,
              help="Upper end of the grid (input unit); default: the largest measured input.")
@click.option("--drift-correct", "drift", type=click.Choice(DRIFT_MODES),
              help="micromag: correct the moments for drift from the calibration points, as a sensitivity "
                   "(scale) or a baseline (offset). Off by default; recorded in the session.")
@click.option("--dwell-from-time", is_flag=True,
              help="csv: take each reading's dwell (set-point change to reading) as the time since the previous "
                   "reading, for a trace that records time stamps but no dwell_s column; the assumption is "
                   "recorded in the session.")
@click.option("--operator", default="", help="Who made the measurement.")
@click.option("--notes", default="", help="Free-text notes stored with the session.")
@click.option("--force", is_flag=True, help="Replace --out if it exists (an earlier import; never an acquisition).")
@click.option("--replace-session", "replace", type=click.Path(dir_okay=False, path_type=Path),
              help="Replace this session even though it holds acquired samples (name --out again).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def import_(file, out, fmt, levels, v_min, v_max, drift, dwell_from_time, operator, notes, force, replace, as_json):
    """Turn FILE (a CSV trace or a MicroMag FORC file) into the session OUT.

    A CSV trace is t_s,v_V,deflection_um with an optional fourth column
    dwell_s (seconds from each set-point change to its reading, as in
    `rig acquire --sequence FILE.csv`); without it the dwells are unknown,
    unless --dwell-from-time takes them from the time stamps.  A thermal
    lag can only be judged on runs that record their dwells.

    With --levels the session records the grid (and recognises the damped
    oscillation of that grid), so `rig identify OUT` needs no --levels.
    A FORC file becomes every applied point of its protocol (saturation,
    calibration field, each curve), its calibration points a drift monitor.
    """
    if replace is not None:
        if not (out.exists() and replace.exists() and out.samefile(replace)):
            raise UserError(f"--replace-session {replace}: names another file than --out {out}")
        force = True
    else:
        _refuse_replacing_an_acquisition(out, force)
    forc = None
    if fmt == "micromag":
        if dwell_from_time:
            raise UserError("--dwell-from-time applies to CSV traces; a MicroMag file's timing comes from its header")
        forc = read_forc(file)
        import_forc(forc, out, levels=levels, v_min=v_min, v_max=v_max, drift=drift,
                    operator=operator, notes=notes, force=force)
    else:
        if drift is not None:
            raise UserError("--drift-correct needs calibration points: it applies to --format micromag only")
        import_trace(read_trace(file), out, levels=levels, v_min=v_min, v_max=v_max, source=file,
                     operator=operator, notes=notes, force=force, dwell_from_time=dwell_from_time)
    session = read_session(out)
    exc = session.excitation
    summary = {
        "session": str(out),
        "n_samples": session.n_samples,
        "excitation": exc.kind,
        "levels": exc.levels,
        "v_min": exc.v_min,
        "v_max": exc.v_max,
        "thermal_term": exc.thermal_term,
        "status": session.status.value,
        "format": fmt,
        "n_measured": int(session.measured.sum()),
        "input_unit": session.quantities.input_unit,
        "output_unit": session.quantities.output_unit,
        "dwell": exc.dwell.get("policy", "unknown"),
    }
    if forc is not None:
        summary.update(
            header_style=forc.header.style,
            n_curves=len(forc.curves),
            n_calibration=len(session.calibration),
            elapsed_s=exc.extra["timing"]["elapsed_s"],
            overhead_per_point_s=exc.extra["timing"]["overhead_per_point_s"],
            drift_correction=session.drift_correction,
        )
    if as_json:
        print_json(summary)
        return
    unit = session.quantities.input_unit
    grid = f", L={exc.levels} on [{exc.v_min:g}, {exc.v_max:g}] {unit}" if exc.levels else ""
    click.echo(f"{out}: {session.n_samples} samples from {file} ({exc.kind} excitation{grid})")
    if forc is not None:
        drift_text = f"drift-corrected ({drift})" if drift else "not drift-corrected"
        click.echo(f"{len(forc.curves)} curves, {summary['n_measured']} measured points, "
                   f"{len(session.calibration)} calibration points; {drift_text}")
