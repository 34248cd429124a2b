"""Figures of ``rig diagnose --out``: the binned check residuals before and after the chosen effect,
and every candidate's held-out shrink."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from identify.diagnosis import Diagnosis
from identify.diagnosis.binning import Binning

from .style import COLOURS, DEFLECTION, LEGEND_SIZE, TITLE_SIZE, display_unit, label_axes, new_figure

#: Axis labels of the binned quantities (``Diagnosis.where[*].by``).
LABELS = {
    "input_V": "heater voltage (V)",
    "branch": "branch",
    "time_since_reversal_s": "time since the last reversal (s)",
    "last_step_V": "last step (V)",
    "predicted_um": f"predicted {DEFLECTION.label}",
    "session_time_s": "session time (s)",
    "reversal_V": "reversal field",
}


def _label(by: str, unit: str, heater: bool) -> str:
    """The axis label of a binned quantity, in the runs' units (a FORC session: field in, moment out)."""
    if heater or by in ("branch", "time_since_reversal_s", "session_time_s"):
        return LABELS.get(by, by) if by != "reversal_V" else f"input at the last reversal ({unit})"
    names = {"input_V": "applied input", "last_step_V": "last step", "predicted_um": "predicted output",
             "reversal_V": "input at the last reversal"}
    return f"{names.get(by, by)} ({display_unit(unit)})"
BEFORE, AFTER = COLOURS["measured"], COLOURS["model"]


def _positions(w: Binning) -> tuple[np.ndarray, list[str] | None]:
    if w.by == "branch":
        names = [b.label.replace("first step after a reversal", "after reversal") for b in w.bins]
        return np.arange(len(w.bins), dtype=float), names
    return np.array([0.5 * (b.lo + b.hi) for b in w.bins]), None


def _panel(ax: Axes, w: Binning, after: Binning | None, effect: str | None, floor: float | None,
           units: tuple[str, str] = ("V", "um")) -> None:
    x, names = _positions(w)
    shift = 0.25 * (np.min(np.diff(x)) if x.size > 1 else 1.0) if after is not None else 0.0
    for binning, colour, dx, name in ((w, BEFORE, -shift / 2, "base model"),
                                      (after, AFTER, shift / 2, f"with {effect}")):
        if binning is None:
            continue
        bx, _ = _positions(binning)
        mean = np.array([b.mean_um for b in binning.bins])
        rms = np.array([b.rms_um for b in binning.bins])
        out = np.array([b.significant for b in binning.bins])
        ax.errorbar(bx + dx, mean, yerr=rms, fmt="none", ecolor=colour, alpha=0.5, linewidth=1.2)
        ax.plot(bx[out] + dx, mean[out], "o", color=colour, markersize=5, label=f"{name}: bin stands out")
        ax.plot(bx[~out] + dx, mean[~out], "o", mfc="white", color=colour, markersize=5, label=name)
    if floor is not None:
        ax.axhspan(-floor, floor, color=COLOURS["reference"], alpha=0.15, linewidth=0, label="± noise floor")
    ax.axhline(0.0, color=COLOURS["reference"], linewidth=0.8)
    if names is not None:
        ax.set_xticks(x, names)
    label_axes(ax, _label(w.by, w.unit, units == ("V", "um")), f"residual ({display_unit(units[1])})")


def where_figure(d: Diagnosis) -> Figure:
    """Per binned quantity: each bin's mean residual (model - measured; filled where the bin stands
    out beyond noise) and its rms (bar), before and after the chosen effect; grey: +- the noise floor."""
    n = len(d.where)
    cols = 3
    rows = int(np.ceil(n / cols))
    fig, axes = new_figure(rows, cols, size=(13.0, 4.0 * rows + 0.8))
    after = {w.by: w for w in d.where_after} if d.where_after is not None else {}
    for ax, w in zip(axes.flat, d.where):
        _panel(ax, w, after.get(w.by), d.chosen, d.noise_floor_um, (d.input_unit, d.output_unit))
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    handles, names = axes.flat[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, names, loc="outside lower center", fontsize=LEGEND_SIZE, ncols=5)
    v = d.verdict
    title = {"explained": f"explained by {v.effect}", "ambiguous": f"ambiguous: {', '.join(v.contenders)}",
             "unexplained": "unexplained", "no_gap": "no gap"}[v.status]
    fig.suptitle(f"Where the model misses on the check runs -- {title}", fontsize=TITLE_SIZE)
    return fig


def candidates_figure(d: Diagnosis) -> Figure:
    """Every candidate's held-out shrink with its 95 % interval (the named effect highlighted;
    an open marker: the input design cannot show the effect)."""
    fig, axes = new_figure(1, 1, size=(7.0, 0.45 * max(len(d.candidates), 2) + 1.8))
    ax = axes[0, 0]
    y = np.arange(len(d.candidates))[::-1]
    for yi, c in zip(y, d.candidates):
        colour = AFTER if c.effect == d.verdict.effect else BEFORE
        ax.plot([100 * c.ci[0], 100 * c.ci[1]], [yi, yi], color=colour, linewidth=2)
        ax.plot(100 * c.shrink, yi, "o", color=colour, mfc=colour if c.visible else "white")
    ax.axvline(0.0, color=COLOURS["reference"], linewidth=0.8)
    ax.set_yticks(y, [c.effect for c in d.candidates])
    label_axes(ax, "held-out shrink of the RMSE (%)", "candidate effect", "Which effect: held-out improvement")
    return fig
