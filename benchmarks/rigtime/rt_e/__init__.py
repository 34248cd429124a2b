"""rt_e: a blind rig-time device -- a lumped, temperature-dependent thermal network behind the base device.

See ``README.md`` in this folder for the physics, the drawn forms and the definition of ``tau_s``.
"""

from .model import draw_form, instant_form, settling_time_s, simulate

__all__ = ["draw_form", "instant_form", "settling_time_s", "simulate"]
