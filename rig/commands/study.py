"""``rig study``: the paper's simulation study (section 4), ours beside the paper's figures."""

from __future__ import annotations

import os
from pathlib import Path

import click

from identify.methods import DAMPED_METHODS
from identify.profiles import PROFILES
from identify.study import (
    StudySetup, default_measurement_sweep, default_noise_sweep, findings, summarise,
)

from ..errors import UserError
from ..options import AliasedOption, scheduler_option
from ..output import print_json
from ..study_report import study_json, study_text
from ..study_runner import run_study


def _number_list(text: str | None, kind: type, option: str) -> tuple | None:
    if text is None:
        return None
    try:
        values = tuple(kind(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UserError(f"{option} must be a comma-separated list of numbers, got {text!r}") from None
    if not values:
        raise UserError(f"{option} is empty")
    return values


@click.command()
@click.option("--profile", type=click.Choice(PROFILES), default="random", show_default=True,
              help="Density profile: uniform (eq. 20), gaussian (eq. 21) or random (section 4.3).")
@click.option("--runs", type=int, default=1000, show_default=True,
              help="Runs per point, each with fresh noise, rows and (random profile) densities.")
@click.option("--measurements", "-M", type=int, default=300, show_default=True,
              help="Measured rows M, chosen at random among the N damped-oscillation points.")
@click.option("--levels", "-L", type=int, default=30, show_default=True, help="Discretisation levels L.")
@click.option("--noise", type=float, default=10.0, show_default=True,
              help="Noise amplitude D (um): uniform on [-D/2, D/2].")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the whole study.")
@click.option("--method", "methods", type=click.Choice(list(DAMPED_METHODS)), multiple=True,
              help="Method to compare (repeat the option; default: all).")
@click.option("--sweep", is_flag=True,
              help="Also sweep M (multiples of 50 below N) and D (0, 5, 10, 20, 40): figures 4 and 5.")
@click.option("--sweep-measurements", help="Comma-separated M values to sweep (implies the sweep of M).")
@click.option("--sweep-noise", help="Comma-separated D values to sweep (implies the sweep of D).")
@click.option("--validation-points", type=int, default=500, show_default=True,
              help="Length of the random validation input (figure 6).")
@click.option("--workers", type=int, default=None, help="Worker processes (default: the number of cores).")
@scheduler_option
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--out", "-o", "plots", cls=AliasedOption, aliases=("--plots",),
              type=click.Path(file_okay=False, path_type=Path), metavar="DIR", help="Write PNG figures into DIR.")
def study(profile, runs, measurements, levels, noise, seed, methods, sweep, sweep_measurements,
          sweep_noise, validation_points, workers, scheduler, as_json, plots):
    """Reproduce the paper's simulation study and print our results beside the paper's."""
    if workers is not None and scheduler is not None:
        raise UserError("--workers sets the local processes; with --scheduler the cluster's workers run the study")
    if workers is None:
        workers = os.cpu_count() or 1
    if workers < 1:
        raise UserError(f"--workers must be at least 1, got {workers}")
    m_sweep = _number_list(sweep_measurements, int, "--sweep-measurements")
    d_sweep = _number_list(sweep_noise, float, "--sweep-noise")
    setup = StudySetup(profile=profile, levels=levels, measurements=measurements, runs=runs, noise=noise,
                       seed=seed, methods=tuple(methods) or tuple(DAMPED_METHODS),
                       validation_points=validation_points)
    if sweep or m_sweep:
        m_sweep = m_sweep or default_measurement_sweep(setup.n_points)
    if sweep or d_sweep:
        d_sweep = d_sweep or default_noise_sweep()
    if m_sweep or d_sweep:
        setup = StudySetup(**{**setup.__dict__, "sweep_measurements": m_sweep or (),
                              "sweep_noise": d_sweep or ()})
    if plots is not None:  # fail now, not after the whole study
        try:
            plots.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UserError(f"cannot write the figures to {plots}: {exc.strerror or exc}") from None
    summary = summarise(setup, run_study(setup, workers, scheduler=scheduler))
    found = findings(summary)
    written: list[str] = []
    if plots is not None:
        from ..plots.study import study_figures
        from ..plots.style import save_figure

        try:
            written = [str(save_figure(fig, plots / name)) for name, fig in study_figures(summary).items()]
        except OSError as exc:
            raise UserError(f"cannot write the figures to {plots}: {exc.strerror or exc}") from None
    if as_json:
        print_json(study_json(summary, found, written))
    else:
        click.echo(study_text(summary, found, written))
