"""Blind generator ``gen_k``: a metrologist's view of the unmodelled effects of the VO2 rig.

Exposes ``LIBRARY``, ``OUTSIDE``, ``draw_form`` and ``simulate`` as ``SPEC.md`` asks; see
``README.md`` for the physics and the forms drawn.
"""

from .engine import simulate
from .forms import LIBRARY, OUTSIDE, draw_form

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
