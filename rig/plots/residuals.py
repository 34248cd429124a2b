"""Model residual against input, coloured by branch (heating or cooling); predicted against measured."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from identify.branch import COOLING, HEATING

from .style import COLOURS, MARKERS, Quantity, display_unit, label_axes, legend, new_figure


def residual_panel(ax: Axes, inputs: np.ndarray, residual: np.ndarray, branch: np.ndarray,
                   input_q: Quantity, output_q: Quantity, title: str | None = None) -> None:
    """Draw the residual (model minus measured) against input, one colour and marker per branch."""
    v = np.asarray(inputs, dtype=float)
    r = np.asarray(residual, dtype=float)
    b = np.asarray(branch)
    ax.axhline(0.0, color=COLOURS["reference"], linewidth=0.8)
    for code, name in ((HEATING, "heating"), (COOLING, "cooling")):
        on = b == code
        ax.plot(v[on], r[on], linestyle="none", marker=MARKERS[name], markersize=4.5, color=COLOURS[name],
                label=f"{name} ({int(on.sum())})")
    label_axes(ax, input_q.label, f"residual, model − measured ({display_unit(output_q.unit)})", title)
    legend(ax, loc="best")


def residual_figure(
    inputs: np.ndarray,
    residual: np.ndarray,
    branch: np.ndarray,
    input_q: Quantity,
    output_q: Quantity,
    *,
    title: str | None = None,
) -> Figure:
    """Residual (model minus measured, output units) against input at the measured points.

    ``inputs``, ``residual`` and ``branch`` (+1 heating, -1 cooling, see
    :func:`identify.branch.branches`) have shape ``(m,)``.  Systematic
    structure here -- one branch above zero, the other below -- is
    hysteresis the model has not captured.
    """
    fig, axes = new_figure()
    residual_panel(axes[0, 0], inputs, residual, branch, input_q, output_q, title)
    return fig


def prediction_figure(
    inputs: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray,
    branch: np.ndarray,
    input_q: Quantity,
    output_q: Quantity,
    *,
    title: str | None = None,
) -> Figure:
    """Two panels: the model's prediction against the measurement (on the diagonal when they agree),
    and the residual against input by branch (:func:`residual_panel`).

    All arrays have shape ``(m,)``, one entry per measured point compared;
    ``measured`` and ``predicted`` in output units, ``inputs`` in input units.
    """
    y = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    fig, axes = new_figure(1, 2, size=(11.0, 4.6))
    ax = axes[0, 0]
    if y.size:
        lo, hi = float(min(y.min(), p.min())), float(max(y.max(), p.max()))
        ax.plot([lo, hi], [lo, hi], color=COLOURS["reference"], linewidth=0.8, label="predicted = measured")
    ax.plot(y, p, linestyle="none", marker=MARKERS["measured"], markersize=3.5, markerfacecolor="none",
            color=COLOURS["model"], label=f"points ({y.size})")
    label_axes(ax, f"measured {output_q.label}", f"predicted {output_q.label}", "Predicted against measured")
    legend(ax, loc="upper left")
    residual_panel(axes[0, 1], inputs, p - y, branch, input_q, output_q, "Residual by branch")
    if title is not None:
        fig.suptitle(title, fontsize=axes[0, 0].title.get_fontsize())
    return fig
