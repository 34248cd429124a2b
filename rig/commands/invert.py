"""``rig invert``: the heater voltages that make a model's output follow a target sequence, offline."""

from __future__ import annotations

from pathlib import Path

import click

from identify.inverse import invert as invert_targets
from sessions import DataFileError
from sessions.targets import read_targets, write_setpoints

from ..output import format_table, print_json
from ..tracking.source import check_targets, check_units, load_source


@click.command()
@click.argument("source", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("target", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "-o", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Set-point file to write: t_s,v_V,target_um,predicted_um,reachable.")
@click.option("--model", "model_name", help="With a session as SOURCE: the stored model (default: the most recent).")
@click.option("--force", is_flag=True, help="Replace --out if it exists.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def invert(source, target, out, model_name, force, as_json):
    """Invert the model in SOURCE for the targets in TARGET (t_s,target_um) and write the set-points to --out.

    SOURCE is a session holding the model (--model NAME, as rig validate
    names it) or a model JSON file (as rig predict takes). The memory starts
    at negative saturation; each target is reached from the memory state the
    previous set-points left, by the voltage nearest the previous one (then
    the least heater power); a target no voltage reaches is reported
    unreachable with the closest output the model can give. Nothing is
    applied to any rig.
    """
    src = load_source(source, model_name)
    check_units(src)
    targets = read_targets(target)
    if out.exists() and not force:
        raise DataFileError(f"{out}: already exists; use --force to replace it")
    if out.exists() and out.resolve() in (Path(target).resolve(), Path(source).resolve()):
        raise DataFileError(f"{out}: is an input of this command; write the set-points elsewhere")
    g = src.model.grid
    domain = (g.v_min, g.v_max)
    lo, hi = check_targets(src, targets, domain, target)
    result = invert_targets(src.model, targets.target_um, targets.t_s, targets.dwell_s, domain=domain,
                            run_name=Path(target).stem)
    write_setpoints(out, targets.t_s, result.voltages, result.targets, result.predicted, result.reachable)
    err = (result.predicted - result.targets)[result.reachable]
    summary = {
        "source": str(source),
        "model": src.record.name,
        "method": src.record.method,
        "effects": [e.name for e in src.model.effects],
        "target": str(target),
        "out": str(out),
        "n": len(targets),
        "unreachable": result.n_unreachable,
        "output_range_um": [lo, hi],
        "v_range_V": [float(result.voltages.min()), float(result.voltages.max())],
        "max_abs_reached_um": float(abs(err).max()) if err.size else 0.0,
        "seconds": result.seconds,
        "us_per_step": 1e6 * result.seconds / len(targets),
    }
    if as_json:
        print_json(summary)
        return
    click.echo(f"{out}: {len(targets)} set-points for {target} with {src.describe()}")
    click.echo(format_table(["targets", "unreachable", "v_min_V", "v_max_V", "us_per_step"],
                            [[len(targets), result.n_unreachable, summary["v_range_V"][0], summary["v_range_V"][1],
                              summary["us_per_step"]]]))
    if result.n_unreachable:
        k = int(min(i for i, ok in enumerate(result.reachable) if not ok))
        click.echo(f"unreachable: {result.n_unreachable} target(s), the first on {targets.where(k)} of {target}, "
                   f"t = {targets.t_s[k]:g} s "
                   f"({result.targets[k]:.6g} um; closest output {result.closest[k]:.6g} um); see the reachable column",
                   err=True)
