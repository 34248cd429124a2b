"""Blind generator G: unmodelled effects on the VO2 microactuator rig, written from SPEC.md alone.

Written as a bench experimentalist sees them: the film's grains and their clamping by the substrate,
the beam as a bimorph, the optical lever, the PSD and the lab around it.  See README.md.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .sim import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
