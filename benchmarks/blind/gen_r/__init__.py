"""Blind generator ``gen_r`` (see README.md): unmodelled VO2-film and rig effects on top of ``base``."""

from .generator import LIBRARY, OUTSIDE, draw_form, simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
