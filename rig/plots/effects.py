"""A model's effects over a run: each effect's contribution against time, above the residual."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .style import COLOURS, MARKERS, Quantity, display_unit, label_axes, new_figure
from .traces import time_axis


def effects_figure(
    t_s: np.ndarray,
    contributions: dict[str, np.ndarray],
    rows: np.ndarray,
    residual: np.ndarray,
    output_q: Quantity,
    *,
    title: str | None = None,
) -> Figure:
    """One panel per effect -- its contribution to the reading (output units) at every applied point,
    ``(n,)`` each, against time -- and below them, on the same time axis, the residual (model minus
    measured) at the measured points ``rows`` ``(m,)``: where an effect's shape lines up with what is
    left of the residual, the model has not captured all of it.  ``t_s`` ``(n,)`` in s.
    """
    x, xlabel = time_axis(t_s)
    unit = display_unit(output_q.unit)
    names = list(contributions)
    fig, axes = new_figure(len(names) + 1, 1, size=(7.5, 1.9 * (len(names) + 1) + 0.8), sharex=True)
    for ax, name in zip(axes[:, 0], names):
        ax.axhline(0.0, color=COLOURS["reference"], linewidth=0.6)
        ax.plot(x, np.asarray(contributions[name], dtype=float), color=COLOURS["model"], linewidth=1.0,
                drawstyle="steps-post")
        label_axes(ax, None, f"{name} ({unit})")
    ax = axes[-1, 0]
    ax.axhline(0.0, color=COLOURS["reference"], linewidth=0.6)
    ax.plot(x[np.asarray(rows)], np.asarray(residual, dtype=float), linestyle="none", marker=MARKERS["measured"],
            markersize=3.0, color=COLOURS["measured"])
    label_axes(ax, xlabel, f"residual ({unit})")
    if title is not None:
        axes[0, 0].set_title(title, fontsize=axes[0, 0].title.get_fontsize() or None)
    return fig
