"""Blind generator ``gen_m``: unmodelled effects on the VO2 microactuator rig, written from the
point of view of a physicist of the VO2 metal-insulator transition.

Modules (one job each):

* ``forms``     -- the mechanisms' names and the random draw of each one's form;
* ``streams``   -- reproducible random streams keyed by purpose (seed, run, mechanism);
* ``paths``     -- slow random paths (drifts) of a run;
* ``logger``    -- the lab's timing of set-points and readings, and the PSD noise;
* ``scales``    -- the device's scales the mechanisms are sized against;
* ``thermal``   -- temperature stage (``thermal_lag``, ``ambient_drift``);
* ``film``      -- film stage (``interaction``, ``accommodation``, ``nucleation_kinetics``);
* ``mechanics`` -- deflection stage (``joule_power``, ``reversible``, ``creep``, ``backlash``, ``first_point``);
* ``sensor``    -- sensor stage (``sensor_nonlinearity``, ``gain_drift``, ``baseline_drift``);
* ``engine``    -- ``simulate``: one session, the stages in their physical order.

See ``README.md``.
"""

from .engine import simulate
from .forms import LIBRARY, OUTSIDE, draw_form

__all__ = ["LIBRARY", "OUTSIDE", "draw_form", "simulate"]
