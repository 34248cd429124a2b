"""Figures of ``rig study --out DIR``: the paper's section 4, in the shared look of every ``rig`` figure.

* :func:`dct_figure` -- ``|q|`` and ``|q_order|`` of one run's true outputs, with
  the 1 % line the sparsity count uses (figure 3a, 3b);
* :func:`errors_figure` -- modelling, density and validation errors per
  method at the main point, the paper's values marked where it gives them
  (Tables 1-2, figures 4 and 6);
* :func:`measurements_figure` -- density and modelling RMSE, fit time and
  validation error against M (figures 4a, 4b, 5b, 6);
* :func:`noise_figure` -- density and modelling RMSE against D (figure 5a).

Every panel has labelled axes with units (µm for outputs and densities); the
normalised errors are, as everywhere in ``rig``, a fraction of the output
range.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from identify.methods import METHODS
from identify.study import PAPER, PointSummary, StudySummary, dct_example
from identify.study.sparsity import THRESHOLD

from .style import COLOURS, LEGEND_SIZE, display_unit, label_axes, legend, new_figure

#: The study's output and density unit.
UM = display_unit("um")
#: Axis label of the errors normalised by the true output's range.
NORMALISED = "fraction of the output range"
#: Markers, given to the methods in their registry's order (ls o, cs s, cs_order ^, cs_order_nn v, cs_nodct x,
#: smooth_nn *, ...), so the sweeps read in grey too.
MARKER_CYCLE = "os^vx*DP<>ph"


def marker(method: str) -> str:
    """The method's marker: by its place in :data:`identify.methods.METHODS` (``.`` for one it does not know)."""
    names = list(METHODS)
    return MARKER_CYCLE[names.index(method) % len(MARKER_CYCLE)] if method in names else "."

#: The metrics plotted: (key in the summary, axis label).
MODEL_RMSE = ("model_rmse", f"modelling RMSE\n({NORMALISED})")
DENSITY_RMSE = ("density_rmse", f"density RMSE ({UM})")
VALIDATION_RMSE = ("validation_rmse", f"validation RMSE\n({NORMALISED})")
SECONDS = ("seconds", "fit time (s)")


def dct_figure(summary: StudySummary) -> Figure:
    """Figure 3: the DCT coefficients of run 0's true outputs, acquisition order and sorted."""
    q, q_order = dct_example(summary.setup)
    fig, axes = new_figure(1, 2, size=(10.0, 4.0))
    for ax, coeffs, name in ((axes[0, 0], q, "q (acquisition order)"), (axes[0, 1], q_order, "q_order (sorted)")):
        mag = np.abs(coeffs)
        small = int(np.sum(mag < THRESHOLD * mag.max()))
        ax.semilogy(np.arange(mag.size), np.maximum(mag, 1e-12), ".", ms=3, color=COLOURS["measured"])
        ax.axhline(THRESHOLD * mag.max(), color=COLOURS["model"], lw=1.0, label="1 % of the largest")
        label_axes(ax, "DCT index", f"|coefficient| ({UM})", f"{name}: {small} of {mag.size} below 1 %")
        legend(ax, loc="upper right")
    fig.suptitle(f"Figure 3: DCT of the outputs, {summary.setup.profile} profile, run 0")
    return fig


def errors_figure(summary: StudySummary) -> Figure:
    """Errors per method at the main (M, D), ours as bars, the paper's as marks."""
    p, profile = summary.main, summary.setup.profile
    names = list(p.per_run)
    paper = PAPER.get(profile, {})
    panels = [(MODEL_RMSE, paper.get("model_rmse", {})), (DENSITY_RMSE, {}),
              (VALIDATION_RMSE, PAPER["random"]["validation_rmse"] if profile == "random" else {})]
    fig, axes = new_figure(1, 3, size=(13.0, 4.4))
    x = np.arange(len(names))
    for ax, ((metric, ylabel), ref) in zip(axes.flat, panels):
        ax.bar(x, [p.mean(n, metric) for n in names], color=COLOURS["measured"], label="ours")
        marked = [(i, ref[n]) for i, n in enumerate(names) if n in ref]
        if marked:
            ax.plot(*zip(*marked), "_", color=COLOURS["model"], ms=22, mew=2.5, label="paper")
        ax.set_xticks(x, names, rotation=30, ha="right")
        ax.set_yscale("log")
        label_axes(ax, "method", ylabel, ylabel.split("\n")[0].split(" (")[0])
        legend(ax)
    fig.suptitle(f"{profile} profile, M = {p.measurements}, D = {p.noise:g} {UM}, {p.runs} runs")
    return fig


def _sweep(ax: Axes, points: list[PointSummary], key: str, metric: tuple[str, str], title: str) -> None:
    name, ylabel = metric
    xs = [getattr(q, key) for q in points]
    for method in points[0].per_run:
        ax.plot(xs, [q.mean(method, name) for q in points], marker=marker(method), label=method)
    ax.set_yscale("log")
    xlabel = "M (measurements)" if key == "measurements" else f"D (noise amplitude, {UM})"
    label_axes(ax, xlabel, ylabel, title)


def _legend_below(fig: Figure, ax: Axes) -> None:
    """One legend for all panels, below them, so it never hides a curve."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=LEGEND_SIZE, frameon=False)


def _sweep_figure(summary: StudySummary, points: list[PointSummary], key: str,
                  panels: list[tuple[tuple[str, str], str]], shape: tuple[int, int], size: tuple[float, float],
                  title: str) -> Figure:
    """Every method's ``panels`` (metric, title) against the swept ``key``, one legend below them all."""
    fig, axes = new_figure(*shape, size=size)
    for ax, (metric, panel_title) in zip(axes.flat, panels):
        _sweep(ax, points, key, metric, panel_title)
    fig.suptitle(title)
    _legend_below(fig, axes.flat[0])
    return fig


def measurements_figure(summary: StudySummary) -> Figure:
    """Figures 4a, 4b, 5b and 6: every method's errors and fit time against M."""
    panels = [(DENSITY_RMSE, "figure 4a: density"), (MODEL_RMSE, "figure 4b: modelling error"),
              (SECONDS, "figure 5b: fit time"), (VALIDATION_RMSE, "figure 6: validation error")]
    return _sweep_figure(summary, summary.measurement_sweep, "measurements", panels, (2, 2), (11.0, 8.0),
                         f"{summary.setup.profile} profile, D = {summary.setup.noise:g} {UM}, "
                         f"{summary.setup.runs} runs per M")


def noise_figure(summary: StudySummary) -> Figure:
    """Figure 5a: density and modelling error against the noise amplitude D."""
    panels = [(DENSITY_RMSE, "figure 5a: density"), (MODEL_RMSE, "modelling error")]
    return _sweep_figure(summary, sorted(summary.noise_sweep, key=lambda q: q.noise), "noise", panels, (1, 2),
                         (11.0, 4.6), f"{summary.setup.profile} profile, M = {summary.setup.measurements}, "
                                      f"{summary.setup.runs} runs per D")


def study_figures(summary: StudySummary) -> dict[str, Figure]:
    """Every figure of the study, by file name (the sweeps only when they were run)."""
    figures = {"fig3_dct.png": dct_figure(summary), "errors.png": errors_figure(summary)}
    if summary.measurement_sweep:
        figures["fig4_measurements.png"] = measurements_figure(summary)
    if summary.noise_sweep:
        figures["fig5a_noise.png"] = noise_figure(summary)
    return figures
