"""The optical read-out: the PSD's nonlinearity, its zero's and gain's slow drifts.

Reading of the spot position ``m`` (um), in order:

1. ``spot = m + b_spot(t)``     (``baseline_drift`` at the spot: laser pointing, the lever settling)
2. ``r = NL(spot)``             (``sensor_nonlinearity``: lateral-effect PSD, spot off centre ``c``)
3. ``r = (1 + g(t)) r``         (``gain_drift``: the reading from the sensor's zero times a wandering factor)
4. ``r = r + b_elec(t)``        (``baseline_drift`` in the electronics: offset warm-up)

``NL`` kinds, all smooth and monotone for every strength, ``d = spot - c``:
``tanh`` ``c + L tanh(d/L)`` (edge compression), ``sinh`` ``c + L sinh(d/L)``
(pincushion-like expansion), ``exp`` ``c + (exp(a d) - 1)/a`` (unequal electrode
gains: one side compressed, the other expanded), ``rational``
``c + d / (1 + |d/L|**q)**(1/q)`` (a sharper knee).  ``L`` or ``a`` is set so
that the departure at the farthest point of the output range is about
``SENSOR_FRACTION`` of the swing per unit strength.
"""

from __future__ import annotations

import numpy as np

from .paths import unit_path
from .scales import BASELINE_FRACTION, GAIN_FRACTION, SENSOR_FRACTION, DeviceRef
from .streams import stream


class Nonlinearity:
    def __init__(self, form: dict, strength: float, ref: DeviceRef) -> None:
        self.kind = form["kind"]
        half = 0.5 * ref.swing_um
        self.c = ref.mid_um + float(form["center_frac"]) * half
        dmax = max(abs(ref.mid_um + half - self.c), abs(ref.mid_um - half - self.c), 1e-9)
        target = SENSOR_FRACTION * ref.swing_um * strength
        if self.kind == "tanh":
            self.L = np.sqrt(dmax**3 / (3.0 * target))
        elif self.kind == "sinh":
            self.L = np.sqrt(dmax**3 / (6.0 * target))
        elif self.kind == "rational":
            self.q = float(form["q"])
            self.L = (dmax ** (self.q + 1.0) / (self.q * target)) ** (1.0 / self.q)
        else:
            self.a = float(form["sign"]) * 2.0 * target / dmax**2

    def __call__(self, spot: float) -> float:
        d = spot - self.c
        if self.kind == "tanh":
            return self.c + self.L * np.tanh(d / self.L)
        if self.kind == "sinh":
            return self.c + self.L * np.sinh(d / self.L)
        if self.kind == "rational":
            return self.c + d / (1.0 + abs(d / self.L) ** self.q) ** (1.0 / self.q)
        return self.c + np.expm1(self.a * d) / self.a


def drift_path(family: str, form: dict, seed: int, run: int, t_s: np.ndarray) -> np.ndarray:
    """The unit path of a sensor drift in one run (from the seed, the run and the family only)."""
    return unit_path(form["path"], stream(seed, run, family), t_s)


class Sensor:
    def __init__(self, ref: DeviceRef, nonlinearity: Nonlinearity | None, baseline: tuple | None,
                 gain: tuple | None) -> None:
        self.ref, self.nl, self.baseline, self.gain = ref, nonlinearity, baseline, gain
        self.b_spot = self.b_elec = self.g = None

    def start_run(self, seed: int, run: int, t_s: np.ndarray) -> None:
        n = len(t_s)
        self.b_spot, self.b_elec, self.g = np.zeros(n), np.zeros(n), np.zeros(n)
        if self.baseline is not None:
            form, s = self.baseline
            b = s * BASELINE_FRACTION * self.ref.swing_um * drift_path("baseline_drift", form, seed, run, t_s)
            if form["stage"] == "spot":
                self.b_spot = b
            else:
                self.b_elec = b
        if self.gain is not None:
            form, s = self.gain
            per_unit = GAIN_FRACTION * self.ref.swing_um / max(self.ref.rms_um, 1e-9)
            self.g = s * per_unit * drift_path("gain_drift", form, seed, run, t_s)

    def __call__(self, n: int, m: float) -> float:
        r = m
        if self.baseline is not None:
            r = r + self.b_spot[n]
        if self.nl is not None:
            r = self.nl(r)
        if self.gain is not None:
            r = (1.0 + self.g[n]) * r
        if self.baseline is not None:
            r = r + self.b_elec[n]
        return float(r)
