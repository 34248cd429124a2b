"""rt_d: a VO2 cantilever with distributed (1-D) heat conduction, a patchy film and a PSD window.

See README.md.  Public API (SPEC.md): ``draw_form``, ``instant_form``, ``settling_time_s``, ``simulate``.
"""

from .form import draw_form, instant_form
from .settle import settling_time_s
from .simulate import simulate

__all__ = ["draw_form", "instant_form", "settling_time_s", "simulate"]
