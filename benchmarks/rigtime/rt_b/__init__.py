"""rt_b: an independent, blind simulator of the VO2 microactuator's thermal dynamics (README.md)."""

from .sim import characteristic_tau_s, draw_form, instant_form, settling_time_s, simulate

__all__ = ["characteristic_tau_s", "draw_form", "instant_form", "settling_time_s", "simulate"]
