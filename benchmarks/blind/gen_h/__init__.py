"""Blind generator H: the rig's unmodelled mechanisms as dynamical systems (see README.md)."""

from .forms import LIBRARY, OUTSIDE, draw_form
from .simulator import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
