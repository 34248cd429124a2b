"""Blind generator gen_q (optics engineer's view of the VO2 optical-lever rig); see README.md."""

from .generator import LIBRARY, OUTSIDE, draw_form, simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
