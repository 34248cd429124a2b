"""Blind generator F: an instrumentation engineer's view of the VO2 optical-lever rig.

Exposes ``LIBRARY``, ``OUTSIDE``, ``draw_form`` and ``simulate`` as ``SPEC.md`` asks.
See README.md for the mechanisms' families, the outside mechanism ``heater_anneal`` and
the lab logger (time stamps ``t_s`` only, no ``dwell_s`` column).
"""

from .engine import simulate
from .forms import LIBRARY, OUTSIDE, draw_form

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
