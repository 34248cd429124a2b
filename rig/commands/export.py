"""``rig export``: write a session's samples as a CSV trace."""

from __future__ import annotations

import os
from pathlib import Path

import click

from sessions import DataFileError, read_session, write_trace
from sessions.convert import check_replaceable, trace_of_session

from ..options import AliasedOption


@click.command()
@click.argument("session", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "-o", "csv_out", cls=AliasedOption, aliases=("--csv",), required=True,
              type=click.Path(dir_okay=False, path_type=Path), metavar="FILE",
              help="CSV trace to write (t_s,v_V,deflection_um).")
@click.option("--measured-only", is_flag=True,
              help="Write only the measured rows of a session that applied unmeasured points.")
@click.option("--force", is_flag=True, help="Replace --out if it exists.")
def export(session, csv_out, measured_only, force):
    """Write the samples of SESSION as a CSV trace."""
    trace = trace_of_session(read_session(session), measured_only)
    check_replaceable(csv_out, force)
    tmp = csv_out.with_name(f".{csv_out.name}.{os.getpid()}.export")
    try:
        write_trace(tmp, trace)
        os.replace(tmp, csv_out)
    except OSError as exc:
        raise DataFileError(f"{csv_out}: cannot write ({exc.strerror})") from None
    finally:
        tmp.unlink(missing_ok=True)
    click.echo(f"{csv_out}: {len(trace)} samples from {session}")
