"""gen_e: a blind generator of unmodelled effects on the VO2 microactuator rig, written as a materials
physicist / mechanical engineer would (lumped thermal network, viscoelastic kernels, stochastic drift
processes, PSD optics).  See README.md.

``LIBRARY``, ``OUTSIDE``, ``draw_form(family, rng)`` and ``simulate(device, schedules, effects, seed, noise_um)``
follow ``benchmarks/blind/SPEC.md``.  The own outside mechanism is ``heater_aging``.
"""

from ._forms import LIBRARY, OUTSIDE, draw_form
from ._session import simulate

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
