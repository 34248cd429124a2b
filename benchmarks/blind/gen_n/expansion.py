"""``joule_power``: the bimorph (thermal-expansion) term follows the power, not the voltage.

The base device's expansion term is ``thermal_um_per_V * v_thermal`` (linear in
the voltage).  The beam's rise is proportional to the power, ``v**2``, and the
expansion coefficients of the layers grow (or fall) with temperature, so the
physical term is ``thermal_um_per_V * h(v_thermal)`` with

    h(v) = v_ref * r (1 + beta r) / (1 + beta),    r = (v / v_ref)**2,

``v_ref`` the voltage where the linear law was calibrated (``h(v_ref) = v_ref``)
and ``beta`` the relative temperature dependence of the expansion mismatch.  At
strength ``s`` the term is ``v + s c (h(v) - v)``, with ``c`` set so that the
largest departure on ``[0, v_max]`` is ``JOULE_FRACTION`` of the swing per unit
strength.
"""

from __future__ import annotations

import numpy as np

from .scales import JOULE_FRACTION, DeviceRef


class Joule:
    def __init__(self, form: dict, strength: float, device, ref: DeviceRef) -> None:
        self.v_ref, self.beta = float(form["v_ref_V"]), float(form["beta"])
        grid = np.linspace(device.v_min_V, device.v_max_V, 241)
        worst = float(np.max(np.abs(self.h(grid) - grid))) * abs(device.thermal_um_per_V)
        self.mix = strength * JOULE_FRACTION * ref.swing_um / max(worst, 1e-12)

    def h(self, v: np.ndarray | float) -> np.ndarray | float:
        r = np.square(np.asarray(v, dtype=float) / self.v_ref)
        return self.v_ref * r * (1.0 + self.beta * r) / (1.0 + self.beta)

    def __call__(self, v_thermal: float) -> float:
        return float(v_thermal + self.mix * (self.h(v_thermal) - v_thermal))
