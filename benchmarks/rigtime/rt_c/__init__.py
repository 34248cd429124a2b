"""rt_c: a blind rig-time simulator of a VO2 microactuator's thermal dynamics (written from SPEC.md only).

See README.md for the forms drawn and the definition of ``tau_s``.
"""

from .sim import draw_form, instant_form, settling_time_s, simulate

__all__ = ["draw_form", "instant_form", "settling_time_s", "simulate"]
