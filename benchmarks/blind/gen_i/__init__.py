"""Blind generator ``gen_i``: unmodelled effects on the VO2 microactuator rig, written as a MEMS
reliability / micromechanics engineer would (thermal networks, visco-elastic chains, rig drifts,
PSD optics).  See README.md.

``LIBRARY``, ``OUTSIDE``, ``draw_form(family, rng)`` and
``simulate(device, schedules, effects, seed, noise_um)`` as in ``benchmarks/blind/SPEC.md``.

``simulate`` returns, per run, ``t_s`` (time stamp of each averaged reading, s from the run's
start), ``v_V``, ``y_um`` and ``dwell_s`` (this lab's logger writes it: the time from the set-point
change to the averaged reading, i.e. the scheduled dwell plus the command latency and half the
reading burst).
"""

from .engine import simulate
from .forms import LIBRARY, OUTSIDE, draw_form

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
