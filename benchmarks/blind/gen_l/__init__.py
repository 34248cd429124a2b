"""Blind generator L: the read-out/drive-chain engineer's simulator of unmodelled effects.

API (see ``benchmarks/blind/SPEC.md``): ``LIBRARY``, ``OUTSIDE``, ``draw_form``, ``simulate``.
"""

from .core import simulate
from .forms import LIBRARY, OUTSIDE, draw_form

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
