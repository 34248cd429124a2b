"""The hysteresis loop: output against input, measured and modelled."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from identify.branch import COOLING, HEATING

from .style import COLOURS, MARKERS, Quantity, label_axes, legend, new_figure


def loop_figure(
    inputs: np.ndarray,
    outputs: np.ndarray,
    input_q: Quantity,
    output_q: Quantity,
    *,
    model_path: tuple[np.ndarray, np.ndarray] | None = None,
    branch: np.ndarray | None = None,
    title: str | None = None,
) -> Figure:
    """Output against input: the measured points, and the path the model traces.

    ``inputs`` and ``outputs`` (NaN where not measured) have shape ``(n,)``;
    ``model_path`` is ``(v, u)``, the model's output along the input's
    path in applied order (:func:`identify.validation.model_path`), which
    draws the model's branches and loops.  With ``branch`` ``(n,)`` (+1
    heating, -1 cooling, :func:`identify.branch.branches`) the measured
    points take the heating and cooling colours and markers of the
    residual figure, so the two branches of the loop can be told apart.
    """
    v = np.asarray(inputs, dtype=float)
    y = np.asarray(outputs, dtype=float)
    fig, axes = new_figure(size=(6.5, 5.0))
    ax = axes[0, 0]
    if model_path is not None:
        pv, pu = (np.asarray(a, dtype=float) for a in model_path)
        ax.plot(pv, pu, color=COLOURS["model"], linewidth=0.9, alpha=0.85, label="model", zorder=2)
    measured = np.isfinite(y)
    if branch is None:
        ax.plot(v[measured], y[measured], linestyle="none", marker=MARKERS["measured"], markersize=4,
                markerfacecolor="none", color=COLOURS["measured"], label="measured", zorder=3)
    else:
        b = np.asarray(branch)
        for code, name in ((HEATING, "heating"), (COOLING, "cooling")):
            on = measured & (b == code)
            ax.plot(v[on], y[on], linestyle="none", marker=MARKERS[name], markersize=4.5, markerfacecolor="none",
                    color=COLOURS[name], label=f"measured, {name} ({int(on.sum())})", zorder=3)
    label_axes(ax, input_q.label, output_q.label, title)
    legend(ax, loc="best")
    return fig
