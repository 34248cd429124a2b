"""Slow thermal paths of the heater-beam-substrate-package stack (``thermal_lag``).

A lumped (Foster) network: the film's rise above ambient is the beam's fast,
instantaneous response plus slow nodes, each relaxing towards the heater's
steady state ``kelvin_per_V2 * v**2`` with its own time constant, which
depends on the node's own temperature (heat capacity and conductances change
with T).  The steady state is the base device's.  A heater with a positive
TCR driven at constant voltage adds a node of negative weight: its power
sags as the package warms, so the film overshoots and settles.
"""

from __future__ import annotations

import numpy as np

#: Sample points of a dwell (fractions of the time from the set-point change to the reading).
FRACTIONS = np.array([0.0, 0.04, 0.12, 0.3, 0.6, 1.0])
#: Largest total weight of the slow paths (the fast part never vanishes).
MAX_SLOW = 0.9
#: Nominal visible lag at strength 1: the residual a dwell of ``REF_DWELL_S`` leaves of a
#: step, in units of (transition width / full-range rise).
VISIBLE = 0.15
REF_DWELL_S = 10.0
#: Below this a path's residual after ``REF_DWELL_S`` is counted as this (very fast paths).
FLOOR = 0.05


class ThermalLag:
    """State of the slow nodes; ``segment`` walks one set-point and returns the film's rise deficits (K)."""

    def __init__(self, form: dict, strength: float, kelvin_per_V2: float, v_max_V: float, width_C: float):
        taus = np.asarray(form["taus_s"], dtype=float)
        weights = np.asarray(form["weights"], dtype=float)
        tcr = form.get("tcr")
        if tcr:
            taus = np.append(taus, float(tcr["tau_s"]))
            weights = np.append(weights, -float(tcr["relative"]))
        visible = VISIBLE * form["gain"] * width_C / (kelvin_per_V2 * v_max_V**2)
        resid = np.maximum(np.exp(-REF_DWELL_S / taus), FLOOR)
        a = visible * weights / resid
        positive = float(a[a > 0].sum())
        frac = MAX_SLOW * (1.0 - np.exp(-strength * positive / MAX_SLOW))
        a = a * (frac / positive)
        self.tau0 = taus
        self.a = a
        self.tempco = float(form["tau_tempco_per_100K"]) / 100.0
        self.z = np.zeros_like(taus)

    def _advance(self, target: float, dt: float) -> None:
        if dt <= 0:
            return
        tau = self.tau0 * np.maximum(1.0 + self.tempco * self.z, 0.3)
        self.z = target + (self.z - target) * np.exp(-dt / tau)

    def segment(self, kv2: float, a: float, r: float, nxt: float) -> np.ndarray:
        """Deficits ``rise - kv2`` (K) of the heater-driven film rise at ``a + FRACTIONS (r - a)``; ends at ``nxt``."""
        out = np.empty(FRACTIONS.size)
        last = a
        for j, f in enumerate(FRACTIONS):
            t = a + f * (r - a)
            self._advance(kv2, t - last)
            last = t
            out[j] = float(self.a @ (self.z - kv2))
        self._advance(kv2, nxt - last)
        return out
