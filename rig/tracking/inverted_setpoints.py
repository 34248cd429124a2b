"""The set-points of a tracking run: the feedback's command, inverted by the model from its memory state.

:class:`TrackingSetpoints` is the :class:`rig.acquisition.setpoint_source.SetpointSource`
of ``rig track``.  Just before point ``k`` is applied it asks the feedback
law for the output to reach (the target, corrected by what was measured so
far) and the model's inverse for the voltage that reaches it from the
memory state the run has put the actuator in.  Once the point is measured it
advances the model's memory with the voltage applied (at the times the
sequencer recorded), tells the feedback law what was measured, and returns
what the session records beside the standard columns: ``target``,
``command``, ``predicted`` (the model at the voltage applied) and
``reachable``.

Everything it holds is a function of the points recorded, so a resumed run
rebuilds it exactly (:meth:`TrackingSetpoints.replay`).
"""

from __future__ import annotations

import math

import numpy as np

from identify.inverse import Feedback, Inverter


class TrackingSetpoints:
    """Set-points for ``targets`` (um, ``(n,)``) through ``model``'s inverse and a ``feedback`` law, within
    ``domain`` (V, the heater's window); ``run_name`` names the session (per-run effects)."""

    def __init__(self, model, targets: np.ndarray, feedback: Feedback, domain: tuple[float, float],
                 run_name: str) -> None:
        self.targets = np.asarray(targets, dtype=float)
        self.feedback = feedback
        self.inverter = Inverter(model, domain=domain, run_name=run_name, initial_V=0.0)
        self._pending: tuple[int, float, float, bool] | None = None  # (k, command, v, reachable)

    def finished(self, k: int, t_s: float) -> bool:
        """A tracking run follows every target: never ends early."""
        return False

    def setpoint(self, k: int, t_s: float, dwell_s: float) -> float:
        y = float(self.targets[k])
        command = self.feedback.command(k, y)
        step = self.inverter.solve(command, t_s + dwell_s if math.isfinite(dwell_s) else t_s, dwell_s)
        self._pending = (k, command, step.v, step.reachable)
        return step.v

    def dwell_for(self, k: int) -> float | None:
        return None  # a tracking run waits the run's own dwell

    def measured(self, k: int, v: float, t_s: float, dwell_s: float, deflection_um: float) -> dict[str, float]:
        if self._pending is None or self._pending[0] != k or self._pending[2] != v:
            raise RuntimeError(f"point {k} was applied at {v!r} V, not at the set-point computed for it")
        _, command, _, reachable = self._pending
        self._pending = None
        return self._advance(k, v, t_s, dwell_s, deflection_um, command, reachable)

    def _advance(self, k: int, v: float, t_s: float, dwell_s: float, deflection_um: float, command: float,
                 reachable: bool) -> dict[str, float]:
        # ``reachable`` is the inversion's verdict at the planned times; the model at the times the
        # sequencer recorded (a dwell a few ms longer) differs by what a lag or a creep does in those ms,
        # which is not a target out of reach (nor a reason for the feedback to stop learning)
        predicted = self.inverter.apply(v, t_s, dwell_s)
        reachable = bool(reachable)
        y = float(self.targets[k])
        self.feedback.observe(k, y, deflection_um, reachable)
        return {"target": y, "command": command, "predicted": predicted, "reachable": reachable}

    def replay(self, inputs: np.ndarray, t_s: np.ndarray, dwell_s: np.ndarray, outputs: np.ndarray,
               commands: np.ndarray, reachable: np.ndarray) -> None:
        """Rebuild the state after the points a session recorded (all ``(m,)``): the model's memory and
        the feedback's learning, as they were when the run stopped."""
        for k in range(len(inputs)):
            self._advance(k, float(inputs[k]), float(t_s[k]), float(dwell_s[k]), float(outputs[k]),
                          float(commands[k]), bool(reachable[k]))
