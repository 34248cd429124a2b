"""Deflection stage: from the film's phase and the beam's temperature to the beam tip's position (um).

Base: ``u = bias + thermal_um_per_V * v_th + phase`` (``base.BaseDevice.output``).
Then, in this order:

``joule_power``  the bimorph term follows the beam's temperature rise (the heater
                 power, ``v_th^2``), with an expansion mismatch that may change
                 with temperature; the part the linear term misses is added.
``reversible``   an anhysteretic, single-valued contribution of the film's (or the
                 heater's) temperature rise: the continuous part of the lattice's
                 change near the transition, or an elastic nonlinearity.
``creep``        visco-elastic relaxation after every change of the deflection
                 (Prony series of relaxation times from seconds to hours).
``backlash``     play in the optical lever's mount (outside mechanism).
``first_point``  a transient tied to each reversal of the heating direction.

Every class here is only built for a strength > 0; units um, K, V, s.
"""

from __future__ import annotations

import numpy as np


class JoulePower:
    """Missing part of the bimorph term (um) at beam temperature ``v_th`` (equivalent V)."""

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        self.v_max = float(device.v_max_V)
        self.shape, self.gamma = form["shape"], float(form["gamma"])
        sign = 1.0 if device.thermal_um_per_V >= 0 else -1.0  # the bimorph's bending direction
        grid = np.linspace(0.0, 1.0, 201)
        peak = np.max(np.abs(self._excess(grid)))
        self.amp = sign * strength * float(form["frac"]) * scales.swing_um / max(peak, 1e-12)

    def _excess(self, y: np.ndarray) -> np.ndarray:
        """Normalised expansion ``h(p)`` minus the linear term, ``y = v_th / v_max``, ``p = y^2``."""
        p = y * y
        if self.shape == "power":
            h = p
        elif self.shape == "power_tc":  # expansion mismatch linear in temperature
            h = p * (1.0 + self.gamma * p) / (1.0 + self.gamma)
        else:  # mismatch saturating at high temperature
            h = (1.0 - np.exp(-self.gamma * p)) / (1.0 - np.exp(-self.gamma))
        return h - y

    def __call__(self, v_th: float) -> float:
        return float(self.amp * self._excess(np.array([v_th / self.v_max]))[0])


class Reversible:
    """Anhysteretic deflection (um) as a function of a temperature rise (K); zero at the rest state."""

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        self.variable = form["variable"]
        self.shape = form["shape"]
        self.c = scales.rise_mid_K + float(form["centre_offset_K"])
        self.w = float(form["width_K"])
        self.p = float(form["exponent"])
        self.r_max = scales.rise_max_K
        self.k = float(device.kelvin_per_V2)
        grid = np.linspace(0.0, self.r_max, 401)
        f = self._raw(grid) - self._raw(np.zeros(1))[0]
        self.f0 = self._raw(np.zeros(1))[0]
        self.amp = float(form["sign"]) * strength * float(form["frac"]) * scales.swing_um / max(np.max(np.abs(f)), 1e-12)

    def _raw(self, r: np.ndarray) -> np.ndarray:
        th = (r - self.c) / self.w
        if self.shape == "sigmoid":  # a reversible share of the structural change
            return 1.0 / (1.0 + np.exp(-th))
        if self.shape == "bump":  # pretransitional softening, largest at the transition
            return np.exp(-0.5 * th * th)
        if self.shape == "power":  # elastic nonlinearity of the thermally stressed beam
            return (np.maximum(r, 0.0) / self.r_max) ** self.p
        return np.logaddexp(0.0, th)  # onset: a contribution switching on smoothly above c

    def __call__(self, x_film: float, v: float) -> float:
        r = self.k * (x_film * x_film if self.variable == "film" else v * v)
        return float(self.amp * (self._raw(np.array([r]))[0] - self.f0))


class Creep:
    """Visco-elastic relaxation after changes of the deflection (um).

    State ``e_j`` (um): the unrelaxed part of past changes in relaxation channel ``j``; the
    reading is offset by ``sum_j c_j e_j``.  ``c_j > 0``: the beam lags and creeps on towards its new
    shape; ``c_j < 0``: it overshoots and relaxes back (stress relaxation of the transformation strain).
    """

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        self.tau = np.asarray(form["tau_s"], dtype=float)
        sign = 1.0 if form["sign"] == "lag" else -1.0
        self.c = sign * strength * float(form["total"]) * np.asarray(form["weights"], dtype=float)
        self.source = form["source"]
        self.p = float(form["size_exponent"])
        self.asym = float(form["asymmetry"])
        self.ref = 0.25 * scales.swing_um
        self.bound = scales.swing_um
        self.e = np.zeros(self.tau.size)
        # the driving quantity at the last change (um): the session starts after a long rest at 0 V
        s = scales.phase_swing_um
        self.last = device.bias_um - s if self.source == "total" else -s

    def _drive(self, delta: float) -> float:
        if delta == 0.0:
            return 0.0
        s = 1.0 if delta > 0 else -1.0
        return s * self.ref * (abs(delta) / self.ref) ** self.p * (1.0 + self.asym * s)

    def change(self, u: float, phase: float) -> None:
        """The deflection changes (at a set-point change) to ``u`` (um), its phase part to ``phase``."""
        q = u if self.source == "total" else phase
        # a channel never holds more than the whole swing unrelaxed (the linear law's own bound);
        # with a size law or a direction asymmetry this caps the ratchet
        self.e = np.clip(self.e - self._drive(q - self.last), -self.bound, self.bound)
        self.last = q

    def decay(self, dt: float) -> None:
        self.e = self.e * np.exp(-dt / self.tau)

    def offset(self, dt: float) -> float:
        """Offset (um) ``dt`` (s) after the last change, without moving the state."""
        return float(self.c @ (self.e * np.exp(-dt / self.tau)))


class Backlash:
    """Play in the optical lever's mount: the mount follows the beam only once the play is taken up."""

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        r = strength * float(form["frac"]) * scales.swing_um
        a = float(form["asymmetry"])
        self.r_up, self.r_dn = r * (1.0 + a), r * (1.0 - a)
        self.follow = float(form["follow"])
        rest = device.bias_um - scales.phase_swing_um  # the deflection after a long time at 0 V
        self.mount = rest + float(form["start"]) * (self.r_dn if form["start"] > 0 else self.r_up)

    def __call__(self, u: float) -> float:
        self.mount = min(max(self.mount, u - self.r_up), u + self.r_dn)
        return self.follow * u + (1.0 - self.follow) * self.mount


class FirstPoint:
    """A transient at every reversal of the heating direction, decaying over the next set-points (um)."""

    def __init__(self, device, scales, form: dict, strength: float) -> None:
        self.amp = strength * float(form["frac"]) * scales.swing_um
        self.mode = 1.0 if form["mode"] == "continue" else -1.0
        self.after_peak, self.after_valley = float(form["after_peak"]), float(form["after_valley"])
        self.law, self.scale = form["size_law"], float(form["size_scale_V"])
        self.linger = float(form["linger"])
        self.v_max = float(device.v_max_V)
        self.reset()

    def reset(self) -> None:
        self.kick, self.age = 0.0, 99

    def _size(self, step: float) -> float:
        if self.law == "const":
            return 1.0
        if self.law == "linear":
            return step / self.v_max * 2.0
        if self.law == "sqrt":
            return np.sqrt(step / self.v_max * 2.0)
        return float(np.tanh(step / self.scale))

    def step(self, reversal: int, step_V: float) -> float:
        """Offset (um) of this reading; ``reversal`` +1 at a valley (now heating), -1 at a peak, 0 none."""
        if reversal != 0:
            side = self.after_valley if reversal > 0 else self.after_peak
            # "continue": the reading still carries the old direction's motion (old direction = -reversal)
            self.kick = self.mode * (-reversal) * self.amp * side * self._size(step_V)
            self.age = 0
        else:
            self.age += 1
        if self.age == 0:
            return self.kick
        if self.linger > 0.0 and self.age <= 4:
            return self.kick * self.linger ** self.age
        return 0.0
