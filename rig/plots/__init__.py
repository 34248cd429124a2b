"""Figures of the ``rig`` command: pure functions that take arrays or models and return a Figure.

* :mod:`rig.plots.style` -- shared look (fonts, colours, units), :func:`save_figure`;
* :mod:`rig.plots.traces` -- input and output against time;
* :mod:`rig.plots.loops` -- the hysteresis loop, measured against model;
* :mod:`rig.plots.density` -- the density on the Preisach triangle;
* :mod:`rig.plots.residuals` -- residual against input by branch;
* :mod:`rig.plots.diagnosis` -- the gap diagnosis: binned residuals before and after, candidates;
* :mod:`rig.plots.effects` -- a model's effects over a run, beside the residual;
* :mod:`rig.plots.study` -- the simulation study (the paper's figures 3-6).

Nothing here reads files or touches ``pyplot``; :func:`save_figure` writes
a PNG with the Agg backend.
"""

from .density import cell_density, density_figure
from .loops import loop_figure
from .residuals import residual_figure
from .style import DEFLECTION, HEATER_VOLTAGE, Quantity, display_unit, save_figure
from .traces import time_figure

__all__ = [
    "DEFLECTION",
    "HEATER_VOLTAGE",
    "Quantity",
    "cell_density",
    "density_figure",
    "display_unit",
    "loop_figure",
    "residual_figure",
    "save_figure",
    "time_figure",
]
