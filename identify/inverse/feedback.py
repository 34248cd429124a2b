"""Feedback around the inverse: what output to ask the inverse for, from the deflections measured so far.

With an exact inverse of the model in front of it, the actuator behaves
like the identity plus the model's error (and the sensor noise): the
deflection measured at a point is the output the inverse was asked for,
plus whatever the model misses there.  So both corrections act in **output
space**: they change the output the inverse is asked for (the *command*),
and the inverse -- the last stage, which respects the memory and the
heater's window -- turns it into a voltage.

* :class:`NoFeedback` -- the command is the target (feed-forward alone).
* :class:`PI` -- a discrete PI on the tracking error ``e = target -
  measured``: ``command_k = target_k + kp e_{k-1} + ki sum_{j<k} e_j``.
  For a static plant of gain 1 the error of a constant offset ``d`` shrinks
  by ``1 - ki`` per point, and white noise of rms ``s`` leaves an error of
  ``s sqrt(2 / (2 - ki))`` (``ki = 0.5``: 1.15 s); the small ``kp`` damps the
  first points.  No integration while the command is unreachable
  (anti-windup).
* :class:`ILC` -- iterative learning control over the repetitions of a
  periodic target (period ``P`` points): ``command_k = target_k + c_{k mod
  P}``, and after each measured point ``c_{k mod P} += gain e_k``, used one
  period later.  A repeating error shrinks by ``1 - gain`` per repetition;
  white noise leaves ``s sqrt(2 / (2 - gain))`` (``gain = 0.7``: 1.24 s, and
  after two learning passes 9 % of the first repetition's repeating
  error).  Unreachable commands teach nothing.

Both are pure functions of the measured history: replaying the recorded
points (a resumed run) rebuilds their state exactly.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from ..errors import IdentifyError

#: The feedback laws, by their command-line name.
FEEDBACKS = ("none", "pi", "ilc")
#: Default gains (see the module doc for what they trade).
PI_KP, PI_KI = 0.1, 0.5
ILC_GAIN = 0.7


class Feedback(Protocol):
    """The output to ask the inverse for at each point, learned from the measured ones."""

    name: str

    def command(self, k: int, target: float) -> float:
        """The output (um) to ask the inverse for at point ``k`` whose target is ``target`` (um)."""

    def observe(self, k: int, target: float, measured: float, reachable: bool) -> None:
        """Point ``k`` (target ``target``) was measured as ``measured`` (um, NaN: not measured); its command
        was ``reachable``."""

    def describe(self) -> dict:
        """The law and its settings (JSON-friendly)."""


class NoFeedback:
    """Feed-forward only."""

    name = "none"

    def command(self, k: int, target: float) -> float:
        return target

    def observe(self, k: int, target: float, measured: float, reachable: bool) -> None:
        pass

    def describe(self) -> dict:
        return {"feedback": "none"}


class PI:
    """``command_k = target_k + kp e_{k-1} + ki sum_{j<k} e_j`` with ``e = target - measured``."""

    name = "pi"

    def __init__(self, kp: float = PI_KP, ki: float = PI_KI) -> None:
        if not (math.isfinite(kp) and math.isfinite(ki) and kp >= 0 and 0 < ki < 2):
            raise IdentifyError(f"PI gains must be kp >= 0 and 0 < ki < 2, got kp={kp}, ki={ki}")
        self.kp, self.ki = float(kp), float(ki)
        self._sum = 0.0
        self._last = 0.0

    def command(self, k: int, target: float) -> float:
        return target + self.kp * self._last + self.ki * self._sum

    def observe(self, k: int, target: float, measured: float, reachable: bool) -> None:
        if not math.isfinite(measured):
            return
        e = target - measured
        self._last = e
        if reachable:
            self._sum += e

    def describe(self) -> dict:
        return {"feedback": "pi", "kp": self.kp, "ki": self.ki}


class ILC:
    """P-type iterative learning over the repetitions of a target of ``period`` points."""

    name = "ilc"

    def __init__(self, period: int, gain: float = ILC_GAIN) -> None:
        if period < 1:
            raise IdentifyError(f"ILC needs a period of at least one point, got {period}")
        if not (math.isfinite(gain) and 0 < gain < 2):
            raise IdentifyError(f"the ILC gain must be in (0, 2), got {gain}")
        self.period, self.gain = int(period), float(gain)
        self._c = np.zeros(self.period)

    def command(self, k: int, target: float) -> float:
        return target + float(self._c[k % self.period])

    def observe(self, k: int, target: float, measured: float, reachable: bool) -> None:
        if math.isfinite(measured) and reachable:
            self._c[k % self.period] += self.gain * (target - measured)

    def describe(self) -> dict:
        return {"feedback": "ilc", "period": self.period, "gain": self.gain}


def period_of(targets: np.ndarray) -> int | None:
    """The shortest period ``P`` (points) with which ``targets`` ``(n,)`` repeats exactly at least twice
    (``targets[k] == targets[k + P]`` for every ``k``, ``n >= 2 P``); None when it does not."""
    y = np.asarray(targets, dtype=float).reshape(-1)
    n = y.size
    for p in range(1, n // 2 + 1):
        if np.array_equal(y[p:], y[: n - p]):
            return p
    return None


def make_feedback(name: str, targets: np.ndarray | None = None, settings: dict | None = None) -> Feedback:
    """The feedback law ``name`` (``none``, ``pi``, ``ilc``); ILC finds its period in ``targets``.

    ``settings`` (a stored :meth:`Feedback.describe`) restores the same law and gains.
    """
    s = dict(settings or {})
    if name == "none":
        return NoFeedback()
    if name == "pi":
        return PI(float(s.get("kp", PI_KP)), float(s.get("ki", PI_KI)))
    if name == "ilc":
        period = s.get("period")
        if period is None:
            period = period_of(targets) if targets is not None else None
            if period is None:
                raise IdentifyError("--feedback ilc learns over the repetitions of a periodic target, and this "
                                    "target does not repeat (give the same sequence at least twice, back to back)")
        return ILC(int(period), float(s.get("gain", ILC_GAIN)))
    raise IdentifyError(f"unknown feedback {name!r}; choose one of {', '.join(FEEDBACKS)}")
