"""The VO2 film: the base Preisach hysteresis, driven by the film's temperature, with the
film-level mechanisms (``interaction``, ``accommodation``) around it.

The hysterons' input is the equivalent voltage of the film's rise above the
device's nominal ambient.  ``interaction`` adds a mean-field shift of every
grain's transition temperature proportional to the current phase deflection,
solved self-consistently; ``accommodation`` changes the weights (or the
thresholds) with the number of transition cycles the film has gone through.
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: Cycles over which an accommodation form's nominal change is reached.
ACC_CYCLES = 30.0


class Accommodation:
    """Training / fatigue of the film: a weight change that follows the cycle count."""

    def __init__(self, form: dict, strength: float, width_C: float, device):
        self.form = form
        self.shape = form["shape"]
        s, g, sign = strength, form["gain"], form["sign"]
        self.unit = {
            "amplitude": 0.02 * s * g * sign,     # relative change of the transformation strain
            "sharpen": 0.12 * s * g * sign,       # weight moved to (from) the densest cells
            "shift": 0.06 * s * g * sign * width_C,  # K: transition temperature drift
            "width": 0.05 * s * g * width_C,      # K: hysteresis widening (fatigue)
        }[self.shape]
        self.S = device.phase_swing_um
        self.cycles = 0.0
        self._state_high = False
        self.twin_device = None
        if self.shape == "sharpen":
            rho = np.asarray(device.density_um, dtype=float)
            mean = float(rho @ rho) / float(rho.sum())
            self.twin_device = dataclasses.replace(device, density_um=rho * (rho / mean - 1.0))
        p0 = form["prior_cycles"]
        self._l0 = self._law(p0)
        self._norm = self._law(p0 + ACC_CYCLES) - self._l0
        self.level = 0.0

    def _law(self, n: float) -> float:
        f = self.form
        n0 = f["n0_cycles"]
        if f["law"] == "exp":
            return 1.0 - np.exp(-n / n0)
        if f["law"] == "log":
            return float(np.log1p(n / n0))
        return float((n / n0) ** f["power"])

    def count(self, p_old: float, p_new: float) -> None:
        if self.form["count"] == "variation":
            self.cycles += abs(p_new - p_old) / (4.0 * self.S)
        else:
            frac = (p_new + self.S) / (2.0 * self.S)
            if not self._state_high and frac > 0.75:
                self._state_high, self.cycles = True, self.cycles + 0.5
            elif self._state_high and frac < 0.25:
                self._state_high, self.cycles = False, self.cycles + 0.5
        self.level = self.unit * (self._law(self.form["prior_cycles"] + self.cycles) - self._l0) / self._norm

    def reset_run(self) -> None:
        self._state_high = False


class Film:
    def __init__(self, device, interaction: tuple[float, float] | None, accommodation: Accommodation | None):
        self.device = device
        self.k = device.kelvin_per_V2
        self.S = device.phase_swing_um
        self.gamma, self.ref = interaction if interaction else (0.0, 0.0)
        self.acc = accommodation
        self.reset()

    def reset(self) -> None:
        """A new run: the film in negative saturation (and an unloaded input play)."""
        self.h = self.device.hysteresis()
        self.twin = self.acc.twin_device.hysteresis() if self.acc and self.acc.twin_device else None
        self.play = 0.0
        self.pb = self.h.value()
        if self.acc:
            self.acc.reset_run()

    # The phase part (um), base weights plus accommodation.
    def _compose(self, pb: float, pt: float | None) -> float:
        acc = self.acc
        if acc is None or acc.level == 0.0:
            return pb
        if acc.shape == "amplitude":
            return pb + acc.level * (pb + self.S)
        if acc.shape == "sharpen":
            return pb + acc.level * (pt + acc.twin_device.phase_swing_um)
        return pb

    def value(self) -> float:
        return self._compose(self.pb, self.twin.value() if self.twin else None)

    def _peek(self, x: float) -> float:
        return self._compose(self.h.peek(x), self.twin.peek(x) if self.twin else None)

    def _move(self, x: float) -> None:
        old = self.pb
        self.pb = self.h.move(x)
        if self.twin:
            self.twin.move(x)
        if self.acc:
            self.acc.count(old, self.pb)

    def _eqv(self, rise: float) -> float:
        return float(np.sqrt(max(rise, 0.0) / self.k))

    def drive(self, v: float, d_rise: float) -> None:
        """Move the film to heater ``v`` (V) with the film's rise off its steady state by ``d_rise`` (K)."""
        acc = self.acc
        shift = acc.level if acc and acc.shape == "shift" else 0.0
        width = acc.level if acc and acc.shape == "width" else 0.0
        base = d_rise + shift
        if self.gamma == 0.0 and width == 0.0:
            if acc is not None and acc.shape == "width":
                self.play = self.k * v * v + base
            self._move(v if base == 0.0 else self._eqv(self.k * v * v + base))
            return
        raw0 = self.k * v * v + base
        play = self.play

        def rise_of(p: float) -> float:
            raw = raw0 + self.gamma * (p - self.ref) / self.S
            return min(max(play, raw - width), raw + width) if width > 0.0 else raw

        if self.gamma == 0.0:
            rise = rise_of(0.0)
        else:
            # Self-consistent mean field: p = phase(x(p)); loop gain < 1, so secant converges.
            p0 = self.value()
            g0 = self._peek(self._eqv(rise_of(p0))) - p0
            p1 = p0 + g0
            tol = 1e-10 * self.S
            for _ in range(30):
                if abs(g0) <= tol:
                    p1 = p0
                    break
                g1 = self._peek(self._eqv(rise_of(p1))) - p1
                if abs(g1) <= tol or g1 == g0:
                    break
                p0, g0, p1 = p1, g1, p1 - g1 * (p1 - p0) / (g1 - g0)
            rise = rise_of(p1)
        if width > 0.0:
            self.play = rise
        self._move(self._eqv(rise))
