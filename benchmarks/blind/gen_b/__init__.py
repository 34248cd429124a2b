"""Blind generator B: unmodelled mechanisms on the VO2 microactuator rig, written from the physics alone.

See ``README.md`` in this folder for every mechanism, the forms drawn, their ranges and why.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .session import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
