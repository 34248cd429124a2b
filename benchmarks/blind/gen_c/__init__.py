"""Blind generator C: an independent simulator of unmodelled effects on the VO2 actuator rig.

Phenomenological, data-driven forms (spectra of time constants, Andrade / stretched relaxation,
random monotone maps, random-walk / sinusoid / jump drifts).  See README.md.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .engine import OVERHEAD_S, READ_PERIOD_S, simulate

__all__ = ["LIBRARY", "OUTSIDE", "OVERHEAD_S", "READ_PERIOD_S", "draw_form", "simulate"]
