"""Temperature: what the film and the expansion term feel (the first stage of the chain).

The film's temperature rise above ambient is ``theta = k_eff * q(t) + dT_amb(t)``:

* ``q`` (V**2): the heater power (``v**2``) seen through the beam's fast
  response (instant at our dwells) and the slow paths into substrate, package and
  surroundings (``thermal_lag``):
  ``q = p + F sum_i w_i (m_i - p) exp(-tau / tau_i)``, ``p = v**2``, ``m_i`` the
  slow paths' low-passed power, ``F`` the signed slow fraction (``F > 0`` lag,
  ``F < 0`` overshoot).  At steady state ``q = p``.
* ``k_eff = k (1 + delta)``: the conductance of the heat paths aging with the
  thermal dose (``conductance_aging``, this generator's own outside mechanism).
* ``dT_amb``: the room's drift reaching the die through the package's low-pass
  (``ambient_drift``); it acts on the film only, not on the heater's rise.

The film's input is the equivalent voltage ``x = sqrt(theta / k)``; the expansion
term follows ``v_thermal = sqrt(k_eff q / k)`` (the beam's own rise).
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .paths import lowpass_on_grid, unit_path
from .scales import AGING_TARGET, AMBIENT_TARGET, LAG_FRACTION_MAX, LAG_TARGET, DeviceRef, input_shift_V
from .streams import stream

#: Where, as fractions of the dwell to the reading, the film's path is sampled when it moves during a dwell.
LAG_SAMPLES = np.array([0.0, 0.04, 0.12, 0.3, 0.6, 1.0])
THETA_REF_K = 40.0


class SlowPaths:
    """``thermal_lag``: the slow heat paths' low-passed power ``m_i`` and the signed slow fraction."""

    def __init__(self, form: dict, strength: float, device, ref: DeviceRef) -> None:
        self.taus, self.w = kernels.prony(form["kernel"])
        residual = float(kernels.value(form["kernel"], 20.0))
        # a full-range step leaves F R(20 s) v_max**2 of power unfelt: dx = F R v_max**2 / (2 x_c)
        wanted = input_shift_V(ref, LAG_TARGET) * 2.0 * ref.center_V / device.v_max_V**2
        per_unit = float(np.clip(wanted / max(residual, 1e-12), 0.0, 0.6))
        cap = LAG_FRACTION_MAX[0] if form["sign"] > 0 else LAG_FRACTION_MAX[1]
        self.fraction = float(form["sign"]) * cap * float(np.tanh(strength * per_unit / cap))
        self.m = np.zeros_like(self.taus)

    def q(self, p: float, offsets: np.ndarray) -> np.ndarray:
        decay = np.exp(-np.asarray(offsets)[:, None] / self.taus[None, :])
        return p + self.fraction * (decay @ (self.w * (self.m - p)))

    def advance(self, p: float, dt: float) -> None:
        self.m = p + (self.m - p) * np.exp(-dt / self.taus)


class Aging:
    """``conductance_aging``: the heat paths' conductance drifts with the thermal dose (README.md)."""

    def __init__(self, form: dict, strength: float, ref: DeviceRef) -> None:
        self.form = form
        # a relative change delta of the rise moves the input at the transition by x_c delta / 2
        per_unit = input_shift_V(ref, AGING_TARGET) * 2.0 / ref.center_V
        self.scale = strength * per_unit * float(form["sign"])
        self.dose_h = 0.0

    def _law(self, d: float) -> float:
        d0, law = float(self.form["dose0_h"]), self.form["law"]
        if law == "exp":
            return (1.0 - np.exp(-d / d0)) / (1.0 - np.exp(-2.0 / d0))
        if law == "sqrt":
            return float(np.sqrt(d / 2.0))
        return float(np.log1p(d / d0) / np.log1p(2.0 / d0))

    @property
    def delta(self) -> float:
        return self.scale * float(self._law(self.dose_h))

    def accumulate(self, theta_K: float, dt: float) -> None:
        hot = max(theta_K, 0.0) / THETA_REF_K
        self.dose_h += hot ** float(self.form["hot_exponent"]) * dt / 3600.0

    def rest(self, dt: float) -> None:
        tau = self.form.get("recovery_tau_s")
        if tau is not None and np.isfinite(dt):
            self.dose_h *= float(np.exp(-dt / float(tau)))


class Ambient:
    """``ambient_drift``: the room's path in one run, through the package's low-pass (K)."""

    def __init__(self, form: dict, strength: float, seed: int, run: int, t_end_s: float, kelvin_per_V: float) -> None:
        def path(times):
            return unit_path(form["path"], stream(seed, run, "ambient_drift"), times)

        self.grid = np.arange(int(np.ceil(t_end_s / 5.0)) + 3) * 5.0
        self.values = strength * kelvin_per_V * lowpass_on_grid(path, self.grid, float(form["package_tau_s"]))

    def at(self, t_s: np.ndarray) -> np.ndarray:
        return np.interp(t_s, self.grid, self.values)


class Thermal:
    """The temperature stage of one session; ``None`` parts are absent mechanisms."""

    def __init__(self, device, ref: DeviceRef | None, lag: SlowPaths | None, aging: Aging | None,
                 ambient_form: tuple | None) -> None:
        self.k = device.kelvin_per_V2
        # ambient: a unit path is the temperature step that moves the input at the transition
        # by input_shift_V(ref, AMBIENT_TARGET): dT = 2 k x_c dx
        self.ambient_K = (2.0 * self.k * ref.center_V * input_shift_V(ref, AMBIENT_TARGET)) if ref is not None else 0.0
        self.lag, self.aging, self.ambient_form = lag, aging, ambient_form
        self.ambient: Ambient | None = None
        self.active = lag is not None or aging is not None or ambient_form is not None

    def start_run(self, seed: int, run: int, gap_s: float, t_end_s: float) -> None:
        if self.lag is not None and np.isfinite(gap_s):
            self.lag.advance(0.0, gap_s)
        if self.aging is not None:
            self.aging.rest(gap_s)
        if self.ambient_form is not None:
            form, strength = self.ambient_form
            self.ambient = Ambient(form, strength, seed, run, t_end_s, self.ambient_K)

    def offsets(self, dwell_read_s: float) -> np.ndarray:
        if self.lag is not None:
            return LAG_SAMPLES * dwell_read_s
        if self.ambient is not None:
            return np.array([0.0, dwell_read_s])
        return np.array([dwell_read_s])

    def setpoint(self, v: float, t0_s: float, offsets: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The film's input along the dwell (V), the expansion term's input at the reading (V), the rise (K)."""
        p = v * v
        q = self.lag.q(p, offsets) if self.lag is not None else np.full(offsets.size, p)
        gain = max(1.0 + self.aging.delta, 0.1) if self.aging is not None else 1.0
        rise = self.k * gain * q
        theta = rise + (self.ambient.at(t0_s + offsets) if self.ambient is not None else 0.0)
        x = np.sqrt(np.maximum(theta, 0.0) / self.k)
        v_thermal = float(np.sqrt(max(rise[-1], 0.0) / self.k))
        return x, v_thermal, float(rise[-1])

    def rest_input(self, t0_s: float = 0.0) -> tuple[float, float]:
        """The film's input and the expansion term's input with the heater off at ``t0_s``."""
        x, vt, _ = self.setpoint(0.0, t0_s, np.array([0.0]))
        return float(x[0]), vt

    def leave(self, v: float, rise_K: float, dt: float) -> None:
        if self.lag is not None:
            self.lag.advance(v * v, dt)
        if self.aging is not None:
            self.aging.accumulate(rise_K, dt)
