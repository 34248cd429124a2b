"""What strength 1 means: the device's reference scales and each mechanism's unit amplitude.

Strength is dimensionless; strength 1 is meant to be a clearly visible effect of
about 1 % of the output swing (calibrated on the sessions of SPEC.md over many
devices and forms, see README.md).  ``DeviceRef`` measures the device once: the
swing of its clean major loop, where its output sits, the steepest slope of its
phase transition and where the transition is.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from ..base import BaseDevice

# --- unit amplitudes at strength 1 (calibrated: README.md, "Calibration") ---------------
#: thermal_lag: after a full-range step and a 20 s dwell, the slow paths' residual moves the film's
#: input by this fraction of the swing, at the transition's steepest slope (per unit strength)
LAG_TARGET = 0.04
#: thermal_lag: the largest slow fraction a form may reach (lag; overshoot)
LAG_FRACTION_MAX = (0.9, 0.5)
#: creep: the not-yet-relaxed part of a change, per unit strength
CREEP_FRACTION = 0.05
#: baseline_drift: path amplitude, fraction of the swing
BASELINE_FRACTION = 0.012
#: ambient_drift: a unit path moves the output at the transition's steepest slope by this fraction of the swing
AMBIENT_TARGET = 0.015
#: joule_power: the largest departure of the expansion term, fraction of the swing
JOULE_FRACTION = 0.02
#: sensor_nonlinearity: the largest departure over the output range, fraction of the swing
SENSOR_FRACTION = 0.018
#: reversible: the largest anhysteretic term, fraction of the swing
REVERSIBLE_FRACTION = 0.015
#: interaction: the mean field's loop gain (at the steepest slope) per unit strength; its cap
INTERACTION_GAIN = 0.05
INTERACTION_GAIN_MAX = 0.7
#: first_point: the transient of a reversing step, fraction of the swing
FIRST_POINT_FRACTION = 0.025
#: gain_drift: the relative gain change per unit path, scaled so |u| ~ rms output gives this fraction of the swing
GAIN_FRACTION = 0.012
#: backlash: the play (full width), fraction of the swing
BACKLASH_FRACTION = 0.02
#: accommodation: after ACCOMMODATION_CYCLES cycles of the session, the weights have grown (or shrunk) by
#: this fraction ("amplitude"), or moved this fraction of the way to their reshaped form ("sharpen", "broaden")
ACCOMMODATION_FRACTION = {"amplitude": 0.04, "sharpen": 0.4, "broaden": 0.4}
ACCOMMODATION_CYCLES = 30.0
#: conductance_aging: after a dose of 2 h at 40 K the rise's change moves the film's input by this
#: fraction of the swing at the transition's steepest slope
AGING_TARGET = 0.02


@dataclass(frozen=True)
class DeviceRef:
    swing_um: float          # range of the clean major loop's output
    mid_um: float            # its midpoint
    rms_um: float            # rms of the clean major loop's output about the sensor's zero
    slope_um_per_V: float    # steepest slope of the phase part along the major loop
    center_V: float          # where the heating branch crosses the middle of the phase swing


def input_shift_V(ref: "DeviceRef", fraction: float) -> float:
    """The shift of the film's input (V) that moves the output by ``fraction`` of the swing at the steepest slope."""
    return fraction * ref.swing_um / ref.slope_um_per_V


_CACHE: "weakref.WeakKeyDictionary[BaseDevice, DeviceRef]" = weakref.WeakKeyDictionary()


def device_ref(device: BaseDevice) -> DeviceRef:
    ref = _CACHE.get(device)
    if ref is None:
        v = np.linspace(device.v_min_V, device.v_max_V, 121)
        h = device.hysteresis()
        up = np.array([h.move(x) for x in v])
        down = np.array([h.move(x) for x in v[::-1]])[::-1]
        u = np.concatenate([device.output(0.0, v) + up, device.output(0.0, v) + down])
        dv = v[1] - v[0]
        slope = float(max(np.max(np.diff(up)), np.max(np.diff(down))) / dv)
        center = float(np.interp(0.0, up, v)) if up[0] < 0.0 < up[-1] else float(0.5 * (v[0] + v[-1]))
        ref = DeviceRef(swing_um=float(np.ptp(u)), mid_um=float(0.5 * (np.max(u) + np.min(u))),
                        rms_um=float(np.sqrt(np.mean(u**2))), slope_um_per_V=max(slope, 1e-9), center_V=center)
        _CACHE[device] = ref
    return ref
