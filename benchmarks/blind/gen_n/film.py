"""The film: the phase transition's memory, with the grains' mean field and the weights' slow change.

* Base: ``phase = Hysteresis.move(x)`` (``base.py``).
* ``interaction``: every grain feels ``z = x + gamma (phase(z) - phase_ref)``,
  solved self-consistently (the phase part is non-decreasing in ``z`` from the
  current memory, and the loop gain ``gamma * slope`` stays below one, so the
  root is unique and reached continuously: no avalanches).
* ``accommodation``: the weights are ``density + c(N) * delta_density``:
  a second ``Hysteresis`` on a device whose density is ``delta_density`` is moved
  alongside, and ``c`` follows the number of cycles ``N`` the film has gone
  through (the transformed throughput: one major loop is one cycle).
* ``reversible``: an anhysteretic, single-valued term of the heater voltage or
  of the film's temperature (equivalent voltage), added to the deflection.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .scales import (ACCOMMODATION_CYCLES, ACCOMMODATION_FRACTION, INTERACTION_GAIN, INTERACTION_GAIN_MAX, REVERSIBLE_FRACTION,
                     DeviceRef)


class MeanField:
    """``interaction``: ``gamma`` (V/um) and the reference phase the field is counted from."""

    def __init__(self, form: dict, strength: float, device, ref: DeviceRef) -> None:
        gain = INTERACTION_GAIN_MAX * float(np.tanh(strength * INTERACTION_GAIN / INTERACTION_GAIN_MAX))
        self.gamma = float(form["sign"]) * gain / ref.slope_um_per_V
        self.reference = -device.phase_swing_um if form["reference"] == "insulating" else 0.0
        self.bound = device.phase_swing_um


class Training:
    """``accommodation``: the change of the weights with the cycles the film has gone through."""

    def __init__(self, form: dict, strength: float, device) -> None:
        d = np.asarray(device.density_um, dtype=float)
        if form["kind"] == "amplitude":
            delta = float(form["sign"]) * d
        else:
            reshaped = np.power(np.maximum(d, 0.0), float(form["exponent"]))
            total = float(np.sum(reshaped))
            delta = (reshaped * float(np.sum(d)) / total - d) if total > 0.0 else np.zeros_like(d)
        self.delta_device = dataclasses.replace(device, density_um=delta)
        self.form, self.scale = form, strength * ACCOMMODATION_FRACTION[form["kind"]]
        self.cycles = 0.0
        self.swing = max(device.phase_swing_um, 1e-12)

    def _law(self, n: float) -> float:
        n0, law = float(self.form["cycles0"]), self.form["law"]
        if law == "exp":
            return float(1.0 - np.exp(-n / n0))
        if law == "log":
            return float(np.log1p(n / n0))
        return float(np.power(n / n0, float(self.form["a"])))

    @property
    def coefficient(self) -> float:
        prior = float(self.form["prior_cycles"])
        span = self._law(prior + ACCOMMODATION_CYCLES) - self._law(prior)
        return self.scale * (self._law(prior + self.cycles) - self._law(prior)) / span

    def count(self, phase_change_um: float) -> None:
        self.cycles += abs(phase_change_um) / (4.0 * self.swing)


class Film:
    def __init__(self, device, field: MeanField | None, training: Training | None) -> None:
        self.device, self.field, self.training = device, field, training
        self.h = device.hysteresis()
        self.h2 = training.delta_device.hysteresis() if training is not None else None
        self.c = 0.0

    def start_run(self) -> None:
        """A run begins in negative saturation (the heater at 0 V for a long time)."""
        self.h = self.device.hysteresis()
        self.h2 = self.training.delta_device.hysteresis() if self.training is not None else None

    def _peek(self, z: float) -> float:
        out = self.h.peek(z)
        if self.h2 is not None:
            out += self.c * self.h2.peek(z)
        return out

    def value(self) -> float:
        out = self.h.value()
        if self.h2 is not None:
            out += self.c * self.h2.value()
        return out

    def _solve(self, x: float) -> float:
        f = self.field
        z = x + f.gamma * (self.value() - f.reference)
        for _ in range(60):
            z_new = x + f.gamma * (self._peek(z) - f.reference)
            if abs(z_new - z) < 1e-11:
                return z_new
            z = z_new
        # slow convergence (loop gain near its cap): bracket and bisect g(z) = z - x - gamma (phase(z) - ref)
        lo = x + min(f.gamma * (-f.bound * 2 - f.reference), f.gamma * (f.bound * 2 - f.reference))
        hi = x + max(f.gamma * (-f.bound * 2 - f.reference), f.gamma * (f.bound * 2 - f.reference))
        from scipy.optimize import brentq

        return float(brentq(lambda s: s - x - f.gamma * (self._peek(s) - f.reference), lo, hi, xtol=1e-12))

    def move(self, x: float) -> float:
        z = self._solve(x) if self.field is not None else x
        if self.h2 is None:
            return self.h.move(z)
        base_before = self.h.value()
        base = self.h.move(z)
        self.training.count(base - base_before)
        return base + self.c * self.h2.move(z)

    def set_weights_for_next(self) -> None:
        if self.training is not None:
            self.c = self.training.coefficient


def path_turns(x_prev: float, xs: np.ndarray) -> list[float]:
    """The inputs a Preisach memory needs from a sampled path: its turning points and its end."""
    out: list[float] = []
    last, direction = x_prev, 0.0
    for x in np.asarray(xs, dtype=float):
        step = x - last
        if step == 0.0:
            continue
        d = 1.0 if step > 0 else -1.0
        if direction != 0.0 and d != direction:
            out.append(last)
        direction, last = d, x
    out.append(float(last))
    return out


class Reversible:
    """``reversible``: ``s * A * f(arg)``, ``f`` smooth, single-valued, ``f(0) = 0``, ``max |f| = 1`` on the range."""

    def __init__(self, form: dict, strength: float, device, ref: DeviceRef) -> None:
        self.form, self.vmax = form, device.v_max_V
        self.center = ref.center_V + float(form.get("center_shift_V", 0.0))
        grid = np.linspace(device.v_min_V, device.v_max_V, 241)
        raw = self._raw(grid) - self._raw(np.zeros(1))[0]
        self.norm = float(np.max(np.abs(raw))) or 1.0
        self.amplitude = strength * REVERSIBLE_FRACTION * ref.swing_um * float(form["sign"])
        self.offset = float(self._raw(np.zeros(1))[0])

    def _raw(self, a: np.ndarray) -> np.ndarray:
        f, kind = self.form, self.form["kind"]
        a = np.asarray(a, dtype=float)
        if kind == "sigmoid":
            return np.tanh((a - self.center) / float(f["width_V"]))
        if kind == "power":
            return np.power(np.maximum(a, 0.0) / self.vmax, float(f["p"]))
        if kind == "bump":
            return np.exp(-0.5 * ((a - float(f["center_V"])) / float(f["width_V"])) ** 2)
        if kind == "saturating":
            return 1.0 - np.exp(-np.maximum(a, 0.0) / float(f["scale_V"]))
        c = f["coeffs"]
        r = a / self.vmax
        return c[0] * r + c[1] * r**2 + c[2] * r**3

    def __call__(self, v: float, x: float) -> float:
        arg = v if self.form["argument"] == "voltage" else x
        return self.amplitude * float(self._raw(np.array([arg]))[0] - self.offset) / self.norm
