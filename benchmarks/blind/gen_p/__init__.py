"""gen_p: a blind generator of unmodelled mechanisms on the VO2 microactuator rig.

Written from ``SPEC.md`` and ``base.py`` only, from a MEMS reliability engineer's point of view:
every mechanism's *form* (kernel, shape, time scales, sign, asymmetry) is drawn at random from a
broad family (:func:`draw_form`); :func:`simulate` runs a session.  See ``README.md``.

The logger writes ``dwell_s``: the actual time from the set-point change to the (mid-burst)
reading, which includes the software latency of the loop.
"""

from .forms import FAMILIES, LIBRARY, OUTSIDE, draw_form
from .session import simulate

__all__ = ["FAMILIES", "LIBRARY", "OUTSIDE", "draw_form", "simulate"]
