"""Blind generator J: unmodelled effects on a VO2 microactuator, written from a thin-film lab's point of view.

Exposes ``LIBRARY``, ``OUTSIDE``, ``draw_form`` and ``simulate`` as ``SPEC.md`` asks; see ``README.md``.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .engine import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
