"""The deflection stage: the beam's creep, a transient at reversals, the lever mount's play.

* ``creep``: every change ``D`` of the (upstream) deflection -- all of it, or its
  phase-transition part -- leaves a part ``s c D`` of it pending, spread over the
  modes of a Prony-series kernel (seconds to hours); the reading is ``u`` minus
  what is still pending.  ``sign = +1``: the beam is still on its way to the new
  shape (visco-elastic lag); ``-1``: it overshoots and the transition's stress
  relaxes back.  The relaxation may be faster in one direction, faster when hot,
  and faster for big changes (``Creep``).
* ``first_point``: the first reading after the input reverses is off by
  ``s * A_dir * size(|step|)``, lingering geometrically on the next set-points.
* ``backlash``: the lever's mount moves only once the beam has taken up its
  play: one play operator (``sharp``) or five of spread widths (``distributed``,
  a gradual take-up); rate independent.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .scales import BACKLASH_FRACTION, CREEP_FRACTION, FIRST_POINT_FRACTION, DeviceRef


class Creep:
    """Per relaxation mode ``i`` the pending part ``p_i`` (um): the beam's shape not yet reached.

    A change ``D`` of the creeping quantity adds ``c w_i D`` to every ``p_i``; then
    each ``p_i`` relaxes to zero with the time ``tau_i`` times ``r_up`` or
    ``r_down`` (by the direction of the change that its sign belongs to), shortened
    when the beam is hot (``exp(-activation * rise / 40 K)``), linearly or, for the
    ``eyring`` size law, as a stress-activated flow
    ``dp/dt = -(p0/tau) sinh(p/p0)`` (big changes relax relatively faster; exact:
    ``tanh(p / 2 p0)`` decays exponentially).  Relaxing towards zero keeps every
    ``p_i`` within ``c w_i`` times the output's range: no ratchet.
    """

    def __init__(self, form: dict, strength: float, ref: DeviceRef) -> None:
        self.form = form
        self.taus, self.w = kernels.prony(form["kernel"])
        self.c = strength * CREEP_FRACTION * float(form["sign"])
        self.p = np.zeros_like(self.taus)
        self.previous: float | None = None
        size = form["size"]
        self.p0 = abs(self.c) * self.w * float(size["x0"]) * ref.swing_um if size["law"] == "eyring" else None
        # the sign of a pending part left by an up-change is the sign of c
        self.up_sign = 1.0 if self.c >= 0 else -1.0
        self.activation = float(form.get("activation", 0.0))

    def launch(self, source_value: float) -> None:
        """The creeping quantity changes to ``source_value`` now."""
        if self.previous is not None:
            d = source_value - self.previous
            if d != 0.0:
                self.p = self.p + self.c * self.w * d
        self.previous = source_value

    def _decayed(self, dt: float, rise_K: float) -> np.ndarray:
        up = np.sign(self.p) == self.up_sign
        factor = np.where(up, float(self.form["up"]), float(self.form["down"]))
        tau = self.taus * factor * float(np.exp(-self.activation * max(rise_K, 0.0) / 40.0))
        e = np.exp(-dt / tau)
        if self.p0 is None:
            return self.p * e
        return 2.0 * self.p0 * np.arctanh(np.tanh(self.p / (2.0 * self.p0)) * e)

    def pending(self, after_s: float, rise_K: float) -> float:
        """The part of the changes not yet arrived, ``after_s`` seconds after the last change."""
        return float(np.sum(self._decayed(after_s, rise_K)))

    def advance(self, dt: float, rise_K: float) -> None:
        self.p = self._decayed(dt, rise_K)


class FirstPoint:
    def __init__(self, form: dict, strength: float, ref: DeviceRef, v_range: float) -> None:
        self.form, self.v_range = form, v_range
        self.scale = strength * FIRST_POINT_FRACTION * ref.swing_um
        self.start_run()

    def start_run(self) -> None:
        self.direction, self.offset, self.v_prev = 0, 0.0, 0.0

    def _size(self, step: float) -> float:
        size = self.form["size"]
        if size["law"] == "flat":
            return 1.0
        if size["law"] == "power":
            return (step / self.v_range) ** float(size["p"])
        return float(1.0 - np.exp(-step / float(size["step0_V"])))

    def __call__(self, v: float) -> float:
        step = v - self.v_prev
        self.v_prev = v
        self.offset *= float(self.form["linger"])
        if step != 0.0:
            d = 1 if step > 0 else -1
            if self.direction != 0 and d != self.direction:
                amp = float(self.form["up"] if d > 0 else self.form["down"])
                self.offset += self.scale * amp * self._size(abs(step))
            self.direction = d
        return self.offset


class Backlash:
    def __init__(self, form: dict, strength: float, ref: DeviceRef) -> None:
        width = strength * BACKLASH_FRACTION * ref.swing_um
        widths = np.array([1.0]) if form["kind"] == "sharp" else np.array([0.2, 0.6, 1.0, 1.4, 1.8])
        a = float(form["asymmetry"])
        narrow, wide = a / (1.0 + a), 1.0 / (1.0 + a)
        lo_share, hi_share = (wide, narrow) if form["low_side_wider"] else (narrow, wide)
        self.lo, self.hi = width * widths * lo_share, width * widths * hi_share
        self.start = form["start"]
        self.m: np.ndarray | None = None

    def __call__(self, u: float) -> float:
        if self.m is None:
            self.m = {"centred": np.full(self.lo.size, u), "low": u - self.lo, "high": u + self.hi}[self.start]
        self.m = np.minimum(np.maximum(self.m, u - self.lo), u + self.hi)
        return float(np.mean(self.m))
