"""Blind generator D: unmodelled effects on the VO2 optical-lever rig, as seen on the bench.

See README.md for every mechanism's family of forms, the logger and the conventions.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .simulate import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
