"""Blind generator ``gen_s`` (the electronics bench's view): see ``README.md``."""

from .generator import FAMILIES, LIBRARY, OUTSIDE, draw_form, simulate

__all__ = ["FAMILIES", "LIBRARY", "OUTSIDE", "draw_form", "simulate"]
