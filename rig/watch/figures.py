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

Every function returns the SVG document as bytes; none touches files.
:func:`draw` runs one of them for a :class:`DrawJob` on the watch's drawing
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


def svg_bytes(fig: Figure) -> bytes:
    """``fig`` as an SVG document: text as text, large point sets rasterised (see the module doc)."""
    for ax in fig.axes:
        for artist in [*ax.lines, *ax.collections]:
            size = len(artist.get_xdata()) if hasattr(artist, "get_xdata") else len(artist.get_offsets())
            if size > RASTER_ABOVE:
                artist.set_rasterized(True)
    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": None}):
        fig.savefig(buf, format="svg", metadata={"Date": None})
    return buf.getvalue()


def time_svg(t_s: np.ndarray, inputs: np.ndarray, outputs: np.ndarray, input_q: Quantity, output_q: Quantity,
             prediction: np.ndarray | None, title: str) -> bytes:
    """Input and output against time (the report's ``time.png``); ``prediction`` ``(n,)`` NaN where the
    model has not been fitted yet."""
    return svg_bytes(time_figure(t_s, inputs, outputs, input_q, output_q, prediction=prediction, title=title))


def loop_svg(inputs: np.ndarray, outputs: np.ndarray, input_q: Quantity, output_q: Quantity,
             path: tuple[np.ndarray, np.ndarray] | None, title: str) -> bytes:
    """The loop in the input-output plane, measured points by branch, and the model's path."""
    return svg_bytes(loop_figure(inputs, outputs, input_q, output_q, model_path=path, branch=branches(inputs),
                                 title=title))


def model_svg(inputs: np.ndarray, outputs: np.ndarray, prediction: np.ndarray, rows: np.ndarray,
              input_q: Quantity, output_q: Quantity, title: str) -> bytes:
    """Predicted against measured and the residual by branch, at the measured points ``rows`` fitted."""
    b = branches(inputs)[rows]
    return svg_bytes(prediction_figure(inputs[rows], outputs[rows], prediction[rows], b, input_q, output_q,
                                       title=title))


def where_svg(diagnosis) -> bytes:
    """The diagnosis's binned residuals (``rig diagnose --out``'s ``where.png``)."""
    from ..plots.diagnosis import where_figure

    return svg_bytes(where_figure(diagnosis))


#: The figures of the page, by name: the function that draws each.
FIGURES = {"time": time_svg, "loop": loop_svg, "model": model_svg, "where": where_svg}


@dataclass(frozen=True, eq=False)
class DrawJob:
    """Draw figure ``name`` (:data:`FIGURES`) with these keyword arguments (arrays, quantities, a title)."""

    name: str
    kwargs: dict[str, Any] = field(default_factory=dict)


def draw(job: DrawJob) -> bytes:
    """The SVG of ``job`` (runs on the drawing worker)."""
    return FIGURES[job.name](**job.kwargs)
