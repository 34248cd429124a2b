"""Temperature stage: what the film and the beam feel, given the heater set-point.

The film's temperature rise above the room, as a function of time ``s`` (s)
since the last set-point change, for heater voltage ``v`` (V):

    H(s) = k * [ (1 - A) * v^2 * Phi(s) + sum_i a_i z_i(s) ]        (K)

* ``k v^2`` is the base device's steady rise (``kelvin_per_V2``); the beam's own
  response (well under a second) is instantaneous here.
* ``z_i`` (V^2) are slow heat paths -- the substrate, the package, the mount --
  each relaxing towards ``v^2`` with its own time constant ``tau_i``; ``a_i`` is
  the share of the steady rise that goes through path ``i`` (``A = sum a_i``).
  While the slow paths are still cold (after heating up) the film is short of
  its steady state; while they are still hot (after cooling) it is above.
* ``Phi = (1 + lam * p) / (1 + lam * q(s))`` is the heater's temperature
  coefficient of resistance: ``q`` (relative) is the package temperature relaxing
  towards ``p = v^2 / v_max^2``; a warmer package raises the heater's
  resistance and lowers the power, so the film overshoots its steady state
  after heating and undershoots after cooling.  ``Phi = 1`` at steady state.

At steady state ``H = k v^2`` exactly, as in the base device.  The film feels
``H`` plus the ambient's drift (``ambient_drift``); the thermal-expansion term
feels ``H`` only.
"""

from __future__ import annotations

import numpy as np

from .paths import SlowPath
from .streams import stream


class ThermalNetwork:
    """The slow heat paths of every ``thermal_lag`` entry, merged into one network.

    ``entries``: list of ``(form, strength)`` with strength > 0.
    """

    def __init__(self, device, entries: list[tuple[dict, float]]) -> None:
        self.k = float(device.kelvin_per_V2)
        self.v_max = float(device.v_max_V)
        a, tau, lam, tau_q = [], [], [], []
        for form, strength in entries:
            # share of the rise through slow paths: ~ strength * lag_fraction, saturating below 1
            total = 1.0 - np.exp(-strength * float(form["lag_fraction"]))
            for p in form["paths"]:
                a.append(total * float(p["weight"]))
                tau.append(float(p["tau_s"]))
            if form.get("tcr"):
                lam.append(strength * float(form["tcr"]["power_drop"]))
                tau_q.append(float(form["tcr"]["tau_s"]))
        self.a = np.array(a)
        self.tau = np.array(tau)
        if self.a.sum() >= 1.0:  # several entries at large strength: keep a fast path
            self.a *= 0.95 / self.a.sum()
        self.lam = np.array(lam)
        self.tau_q = np.array(tau_q)
        self.z = np.zeros(self.a.size)  # V^2; the run starts after a long time at 0 V
        self.q = np.zeros(self.lam.size)

    def rise(self, v: float, s: np.ndarray) -> np.ndarray:
        """Film rise (K) ``(m,)`` at times ``s`` (s) ``(m,)`` after the set-point ``v`` (V) was applied."""
        s = np.asarray(s, dtype=float)[:, None]
        v2 = v * v
        z = v2 + (self.z - v2) * np.exp(-s / self.tau) if self.a.size else np.zeros((s.shape[0], 0))
        phi = np.ones(s.shape[0])
        if self.lam.size:
            p = v2 / self.v_max ** 2
            q = p + (self.q - p) * np.exp(-s / self.tau_q)
            phi = np.prod((1.0 + self.lam * p) / (1.0 + self.lam * q), axis=1)
        return self.k * ((1.0 - self.a.sum()) * v2 * phi + z @ self.a)

    def advance(self, v: float, dt: float) -> None:
        """Hold ``v`` (V) for ``dt`` (s)."""
        v2 = v * v
        if self.a.size:
            self.z = v2 + (self.z - v2) * np.exp(-dt / self.tau)
        if self.lam.size:
            p = v2 / self.v_max ** 2
            self.q = p + (self.q - p) * np.exp(-dt / self.tau_q)


class AmbientDrift:
    """The room/package temperature's slow wander, different in every run (K).

    ``form["rms_K"] * strength`` times a unit path; optional ``bimorph``: the beam
    also bends with the ambient, as the heater's thermal term does per kelvin of
    rise on average (um/K = thermal_um_per_V * v_max / rise at v_max).
    """

    def __init__(self, device, form: dict, strength: float, seed: int, occurrence: int) -> None:
        self.form, self.strength, self.seed, self.occ = form, float(strength), seed, occurrence
        self.amp_K = self.strength * float(form["rms_K"])
        self.um_per_K = float(form["bimorph"]) * device.thermal_um_per_V * device.v_max_V / (
            device.kelvin_per_V2 * device.v_max_V ** 2)
        self.path: SlowPath | None = None

    def start_run(self, run_index: int, t_end_s: float) -> None:
        self.path = SlowPath(
            self.form["path"],
            lambda i: stream(self.seed, "ambient_drift", self.occ, run_index, "path", i),
            t_end_s)

    def delta_K(self, t_s: float | np.ndarray) -> float | np.ndarray:
        """Ambient shift (K) at run time ``t_s`` (s)."""
        return self.amp_K * self.path(t_s)

    def bimorph_um(self, t_s: float) -> float:
        """The beam's own bending (um) from the ambient shift at ``t_s`` (s)."""
        return self.um_per_K * float(self.delta_K(t_s))
