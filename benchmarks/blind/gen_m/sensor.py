"""Sensor stage: the position-sensitive detector's reading of the beam tip (um).

In this order: the PSD's static nonlinearity (``sensor_nonlinearity``), its
sensitivity (``gain_drift``), its zero (``baseline_drift``); the measurement
noise is added by the engine last.  Every class is built only for a
strength > 0; units um, s.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

from .paths import SlowPath
from .streams import stream


def _shape(name: str, a: float):
    """A monotone ``h`` with ``h(0) = 0``, ``h'(0) = 1``."""
    if name == "tanh":  # the spot's tail leaves the active area: compression
        return np.tanh
    if name == "arctan":
        return np.arctan
    if name == "erf":  # Gaussian spot near the edge
        return lambda z: erf(np.sqrt(np.pi) / 2.0 * z)
    if name == "cubic":  # pin-cushion distortion of a duo-lateral PSD: expansion
        return lambda z: z + z ** 3 / 3.0
    return lambda z: np.expm1(a * z) / a  # tilted or non-uniform resistive layer: one-sided


class SensorNonlinearity:
    """``y = u0 + L * (z + eps h(z)) / (1 + eps)``, ``z = (u - u0) / L``: monotone for every ``eps >= 0``.

    ``u0`` (um) is the deflection that puts the spot on the PSD's centre, ``L`` (um) the
    nonlinearity's scale; the output range spans ``z`` in about ``+-span`` around the centre.
    """

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        half = 0.5 * scales.swing_um
        mid = 0.5 * (scales.u_min_um + scales.u_max_um)
        self.u0 = mid + float(form["centre"]) * half
        self.L = half / float(form["span"])
        self.h = _shape(form["shape"], float(form["asymmetry"]))
        z = (np.linspace(scales.u_min_um, scales.u_max_um, 401) - self.u0) / self.L
        dev = np.max(np.abs(self.h(z) - z)) * self.L
        # eps such that eps/(1+eps) * dev = strength * frac * swing at small strength
        self.eps = strength * float(form["frac"]) * scales.swing_um / max(dev, 1e-12)

    def __call__(self, u: float) -> float:
        z = (u - self.u0) / self.L
        return float(self.u0 + self.L * (z + self.eps * self.h(z)) / (1.0 + self.eps))


class _Drift:
    name = ""

    def __init__(self, form: dict, amp: float, seed: int, occurrence: int) -> None:
        self.form, self.amp, self.seed, self.occ = form, amp, seed, occurrence
        self.path: SlowPath | None = None

    def start_run(self, run_index: int, t_end_s: float) -> None:
        self.path = SlowPath(
            self.form["path"], lambda i: stream(self.seed, self.name, self.occ, run_index, "path", i), t_end_s)

    def value(self, t_s: float) -> float:
        return float(self.amp * self.path(t_s))


class GainDrift(_Drift):
    """Relative sensitivity change ``g(t)``: the reading is ``(1 + g) * y``."""

    name = "gain_drift"

    def __init__(self, device, scales, form, strength, seed, occurrence) -> None:
        amp = strength * float(form["rms_frac"]) * scales.swing_um / max(scales.u_abs_max_um, 1e-9)
        super().__init__(form, amp, seed, occurrence)

    def __call__(self, y: float, t_s: float) -> float:
        return (1.0 + self.value(t_s)) * y


class BaselineDrift(_Drift):
    """Additive wander of the PSD's zero (um)."""

    name = "baseline_drift"

    def __init__(self, device, scales, form, strength, seed, occurrence) -> None:
        super().__init__(form, strength * float(form["rms_frac"]) * scales.swing_um, seed, occurrence)

    def __call__(self, y: float, t_s: float) -> float:
        return y + self.value(t_s)
