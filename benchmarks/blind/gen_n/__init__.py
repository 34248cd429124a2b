"""gen_n: a blind simulated VO2 microactuator rig, seen by a MEMS packaging and heat-transfer engineer.

``from benchmarks.blind.gen_n import LIBRARY, OUTSIDE, draw_form, simulate`` (SPEC.md); README.md
describes the mechanisms, their forms and ranges, the logger and the modules.
"""

from .engine import simulate
from .forms import draw_form
from .names import LIBRARY, OUTSIDE

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
