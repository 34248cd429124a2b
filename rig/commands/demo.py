"""``rig demo``: the whole job on the embedded simulated rig -- acquire, identify, diagnose, report."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import click

from drivers.sim import EFFECTS, SimParams, SimVO2
from identify import PreisachModel

from ..options import AliasedOption
from ..output import format_table, print_json


#: How long ``rig demo`` takes with the defaults (L = 30) on a quiet 2-core machine (s), for its progress line:
#: 23-32 s of CPU as measured (docs/results/2026-11-27-suite-and-demo.md).
DEMO_SECONDS = 30.0


def _finite(ctx, param, value):
    """``--strength``: a finite number >= 0 (click's FloatRange lets NaN through)."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"must be a finite number >= 0, got {value}")
    return value


def demo_truth(levels: int) -> PreisachModel:
    """The simulated actuator of the demo: the default simulated VO2 device (``drivers.sim``) on L levels.

    Its phase transition, bias and thermal term (eq. 22) are those of the
    ``sim`` driver and ``rig serve-sim``, so the demo, the simulated bench
    and the tests all identify the same device.
    """
    return SimVO2(SimParams(levels=levels)).true_model()


@click.command()
@click.option("--levels", "-L", type=click.IntRange(2, 200), default=30, show_default=True)
@click.option("--measurements", "-M", type=click.IntRange(min=1), default=300, show_default=True,
              help="How many of the identification run's measured points the methods are fitted on.")
@click.option("--with", "effect", cls=AliasedOption, aliases=("--effect",),
              type=click.Choice([*EFFECTS, "none"]), default="creep", show_default=True,
              help="The unmodelled effect switched on in the simulated device (none: the ideal device).")
@click.option("--strength", type=click.FloatRange(min=0), default=None, callback=_finite,
              help="The effect's strength [the calibrated demo strength: a gap about ten times the noise].")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--out", "-o", "out_dir", type=click.Path(path_type=Path),
              help="Directory for the sessions, the diagnosis figures and the report "
                   "[a new directory rig-demo-* in the system's temporary directory].")
@click.option("--force", is_flag=True, help="Replace an earlier demo's sessions, report/ and diagnosis/ in --out.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def demo(levels, measurements, effect, strength, seed, out_dir, force, as_json):
    """Acquire, identify, diagnose and report on the simulated VO2 rig, in seconds.

    Records an identification run (damped oscillation) and a held-out check
    run (random reversals) on the simulated device with one unmodelled
    effect switched on, identifies equation (22) with the paper's methods
    and ours on M of the identification points, scores every model on the
    check run, diagnoses the gap (where, which effect, how far it shrinks)
    and writes the report. Every file stays in --out for rig identify,
    validate, diagnose and report to look at again.
    """
    # the pipeline (diagnosis, plots) is imported here, not when the rig command starts
    from ..demo_pipeline import DemoSettings, run_demo
    from ..fit_progress import FitProgress

    settings = DemoSettings(levels=levels, measurements=measurements, effect=None if effect == "none" else effect,
                            strength=strength, seed=seed)
    out = Path(tempfile.mkdtemp(prefix="rig-demo-")) if out_dir is None else out_dir
    # on a terminal, the step it is in and about how long is left (about 30 s at L = 30 on a quiet machine)
    with FitProgress("rig demo", DEMO_SECONDS * max(1.0, (levels / 30) ** 2)) as shown:
        result = run_demo(settings, out, progress=shown.stage, force=force)
    if as_json:
        print_json(result.to_json())
        return
    what = (f"{settings.effect} switched on (strength {settings.effect_strength:g})" if settings.effect
            else "no unmodelled effect")
    click.echo(f"Simulated VO2 rig, L={levels}, {what}; files in {out}")
    click.echo(f"\n1. acquire: {result.fit_path.name} (damped oscillation, {result.fit_points} points) and "
               f"{result.check_path.name} (check run, {result.check_points} points) in "
               f"{result.acquire_seconds:.1f} s on the virtual clock")
    click.echo(f"\n2. identify on {measurements} of the {result.fit_points} points; models stored in "
               f"{result.fit_path.name}, validated on {result.check_path.name}:")
    rows = [[m["method"], m["fit_rmse_um"], m["validation_rmse_um"], m["validation_nrmse"], m["seconds"]]
            for m in result.methods]
    click.echo(format_table(["method", "fit_rmse_um", "check_rmse_um", "check_nrmse", "seconds"], rows))
    click.echo("\n3. diagnose (rig diagnose --fit {} --check {}):\n".format(result.fit_path.name,
                                                                           result.check_path.name))
    click.echo(result.diagnosis_text)
    click.echo(f"\n4. report: {result.report_path} ({len(result.figures)} figures)")
