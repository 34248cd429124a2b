"""The page's figures: the ``rig report`` figures of :mod:`rig.plots`, drawn as SVG for a browser.

Why server-side SVG from matplotlib, not a JavaScript plotting library:
the figures are the very functions ``rig report`` and ``rig diagnose``
draw with (:mod:`rig.plots`: the shared style, the heating/cooling
colours and markers, units from the session), so the live view and the
report look the same and stay the same as either changes; the package
needs nothing it does not already depend on, nothing to vendor and
nothing from the network at run time; and any browser shows SVG, a
phone's included.

Two details make the SVG fit a live page:

* text stays text (``svg.fonttype: none``): labels are crisp at any zoom,
  selectable, and readable by a test from the page itself;
* drawings of many points are rasterised inside the SVG (axes, ticks and
  text stay vector), so a 20,000-point loop is an image of a few tens of
  kilobytes instead of 20,000 vector markers for the browser to lay out.

A third keeps redrawing cheap: a figure redrawn with the same texts (titles,
axis labels, tick labels) gets the same layout, so :class:`Drawer` keeps the
layout matplotlib's constrained-layout engine computed for those texts and
reuses it (a third of the drawing time of a small figure), computing it
again whenever a text changes.  Counts that change at every sample are
therefore shown by the page, not in the figures' titles.

Every function returns a Figure or the SVG document as bytes; none touches
files.  A :class:`Drawer` draws :class:`DrawJob` s on the watch's drawing
worker process, so that drawing a 20,000-point figure never holds up the
server's answers.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from identify.branch import branches

from ..plots import loop_figure, time_figure
from ..plots.residuals import prediction_figure
from ..plots.style import Quantity

#: Artists drawing more points than this are rasterised inside the SVG.
RASTER_ABOVE = 2000


def _layout_key(name: str, fig: Figure) -> tuple:
    """Everything the constrained layout of ``fig`` depends on: its size and every text around its axes."""
    texts: list = [name, tuple(fig.get_size_inches()), fig.get_suptitle()]
    for ax in fig.axes:
        texts += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        for axis in (ax.xaxis, ax.yaxis):
            texts.append(tuple(axis.get_major_formatter().format_ticks(axis.get_majorticklocs())))
            texts.append(axis.get_offset_text().get_text())
    return tuple(texts)


def svg_bytes(fig: Figure, layouts: dict | None = None, name: str = "") -> bytes:
    """``fig`` as an SVG document: text as text, large point sets rasterised (see the module doc).

    With ``layouts`` (a dict the caller keeps), the axes' positions for these texts are taken from it
    when known, else computed by the figure's layout engine and kept there.
    """
    for ax in fig.axes:
        for artist in [*ax.lines, *ax.collections]:
            size = len(artist.get_xdata()) if hasattr(artist, "get_xdata") else len(artist.get_offsets())
            if size > RASTER_ABOVE:
                artist.set_rasterized(True)
    if layouts is not None:
        key = _layout_key(name, fig)
        positions = layouts.get(key)
        if positions is None:
            fig.draw_without_rendering()  # runs the constrained layout
            layouts[key] = [ax.get_position() for ax in fig.axes]
        else:
            fig.set_layout_engine("none")
            for ax, position in zip(fig.axes, positions):
                ax.set_position(position)
    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig.savefig(buf, format="svg", metadata={"Date": None})
    return buf.getvalue()


def time_fig(t_s: np.ndarray, inputs: np.ndarray, outputs: np.ndarray, input_q: Quantity, output_q: Quantity,
             prediction: np.ndarray | None, title: str) -> Figure:
    """Input and output against time (the report's ``time.png``); ``prediction`` ``(n,)`` NaN where the
    model has not been fitted yet."""
    return time_figure(t_s, inputs, outputs, input_q, output_q, prediction=prediction, title=title)


def loop_fig(inputs: np.ndarray, outputs: np.ndarray, input_q: Quantity, output_q: Quantity,
             path: tuple[np.ndarray, np.ndarray] | None, title: str) -> Figure:
    """The loop in the input-output plane, measured points by branch, and the model's path."""
    return loop_figure(inputs, outputs, input_q, output_q, model_path=path, branch=branches(inputs), title=title)


def model_fig(inputs: np.ndarray, outputs: np.ndarray, prediction: np.ndarray, rows: np.ndarray,
              input_q: Quantity, output_q: Quantity, title: str) -> Figure:
    """Predicted against measured and the residual by branch, at the measured points ``rows`` fitted."""
    b = branches(inputs)[rows]
    return prediction_figure(inputs[rows], outputs[rows], prediction[rows], b, input_q, output_q, title=title)


def where_fig(diagnosis) -> Figure:
    """The diagnosis's binned residuals (``rig diagnose --out``'s ``where.png``)."""
    from ..plots.diagnosis import where_figure

    return where_figure(diagnosis)


#: The figures of the page, by name: the function that builds each.
FIGURES = {"time": time_fig, "loop": loop_fig, "model": model_fig, "where": where_fig}
#: Figures whose layout is not kept (a legend outside the axes, placed by the layout engine).
FRESH_LAYOUT = ("where",)


@dataclass(frozen=True, eq=False)
class DrawJob:
    """Draw figure ``name`` (:data:`FIGURES`) with these keyword arguments (arrays, quantities, a title)."""

    name: str
    kwargs: dict[str, Any] = field(default_factory=dict)


class Drawer:
    """Draws :class:`DrawJob` s as SVG, keeping each figure's layout while its texts stay the same
    (one per drawing worker process; see the module doc)."""

    __name__ = "draw"

    def __init__(self) -> None:
        self.layouts: dict[tuple, list] = {}

    def __call__(self, job: DrawJob) -> bytes:
        if len(self.layouts) > 256:  # texts that keep changing: keep the memory bounded
            self.layouts.clear()
        fig = FIGURES[job.name](**job.kwargs)
        return svg_bytes(fig, None if job.name in FRESH_LAYOUT else self.layouts, job.name)
