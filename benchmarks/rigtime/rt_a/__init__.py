"""Rig-time device rt_a: a VO2 microactuator with Foster-network thermal dynamics (see README.md)."""

from .sim import REFERENCE_RISE_K, draw_form, instant_form, settling_time_s, simulate

__all__ = ["REFERENCE_RISE_K", "draw_form", "instant_form", "settling_time_s", "simulate"]
