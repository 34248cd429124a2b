"""Blind generator ``gen_o``: unmodelled mechanisms on the VO2 microactuator rig, as a bench technician sees them.

``LIBRARY``, ``OUTSIDE``, ``draw_form(family, rng)`` and
``simulate(device, schedules, effects, seed, noise_um)``; see README.md.
"""

from .forms import LIBRARY, OUTSIDE, draw_form
from .simulate import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
