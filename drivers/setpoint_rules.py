"""Every rule a heater set-point passes before it is written, and the window of set-points that pass.

:class:`SetpointRules` puts together what :mod:`drivers.limits` allows
(finite, voltage range, heater current) with what the wire carries -- the
value the instrument really receives after a scaled-integer register or a
printed decimal rounds it -- and the instrument's own full scale, where it
is known.  The heater's public ``set_voltage`` asks it before every write
(:class:`drivers.channels.GuardedHeater`), and the acquisition asks it for
every point of a plan before the run starts, so a set-point that would be
refused mid-run is refused at plan time instead, naming the point.

The :attr:`~SetpointRules.window` is the limits' window with its edges
pulled in to the last values the wire carries within the limits (``max_V =
1.1`` on a float32 register is 1.0999999046 V; 3.917 V on an int16 x 100 is
3.91 V), so a plan spanning the window is applied exactly as checked.  It is
*not* narrowed to the instrument's full scale: a configured window the
instrument cannot reach is a configuration to fix (``rig selftest`` says so),
not something to work around silently.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cached_property

from .errors import CodecError, LimitError
from .limits import HeaterLimits
from .protocols import VoltageWindow


def same_setpoint(a: float, b: float) -> bool:
    """Two set-points (V) that are the same as far as the wire and a read-back can tell."""
    return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)


class SetpointRules:
    """``limits``; ``on_wire(v)``: the value the instrument receives for ``v`` (V; may raise
    :class:`CodecError`); ``full_scale_V``: the instrument's output range +-V (None: unknown)."""

    def __init__(self, limits: HeaterLimits, on_wire: Callable[[float], float] | None = None,
                 full_scale_V: float | None = None) -> None:
        self.limits = limits
        self.on_wire = on_wire if on_wire is not None else (lambda v: v)
        self.full_scale_V = full_scale_V

    def _wire(self, volts: float) -> float:
        """The value on the wire for ``volts``, if it passes the limits as asked and as carried."""
        requested = self.limits.check(volts)
        try:
            sent = float(self.on_wire(requested))
        except CodecError as exc:
            raise LimitError(f"heater set-point {requested:g} V cannot be carried to the instrument: {exc}; "
                             "nothing was written", check="resolution", volts=requested) from None
        if sent != requested:
            try:
                self.limits.check(sent)
            except LimitError as exc:
                raise LimitError(
                    f"heater set-point {requested:.9g} V becomes {sent:.9g} V on the wire, which is refused: {exc}",
                    check=exc.check, volts=requested,
                ) from None
        return sent

    def check(self, volts: float) -> float:
        """The value the instrument will receive for ``volts`` (V), or :class:`LimitError` naming the rule."""
        sent = self._wire(volts)
        fs = self.full_scale_V
        if fs is not None and abs(sent) > fs * (1 + 1e-12):
            raise LimitError(f"heater set-point {sent:.9g} V is beyond the instrument's full scale of +-{fs:g} V; "
                             "nothing was written", check="full_scale", volts=float(volts))
        return sent

    def _accepted(self, volts: float) -> bool:
        try:
            self._wire(volts)
        except LimitError:
            return False
        return True

    def _pulled_in(self, edge: float) -> float:
        """The accepted value nearest to ``edge`` on the way to 0 V (on_wire is monotone), as carried."""
        if self._accepted(edge):
            return edge
        inside, outside = 0.0, edge  # 0 V always passes (the safe state)
        for _ in range(200):
            mid = (inside + outside) / 2
            if mid in (inside, outside):
                break
            if self._accepted(mid):
                inside = mid
            else:
                outside = mid
        return self._wire(inside)

    @cached_property
    def window(self) -> VoltageWindow:
        """The set-points accepted (V): the limits' window, edges pulled in to what the wire carries."""
        w = self.limits.window
        lo = w.min_V if not math.isfinite(w.min_V) else self._pulled_in(w.min_V)
        hi = w.max_V if not math.isfinite(w.max_V) else self._pulled_in(w.max_V)
        return VoltageWindow(lo, hi)

    def reaches_beyond_full_scale(self) -> str | None:
        """Why the window reaches beyond the instrument's full scale, or None when it does not (or it is unknown)."""
        fs = self.full_scale_V
        if fs is None:
            return None
        w = self.window
        far = max(abs(w.min_V), abs(w.max_V))
        if far <= fs * (1 + 1e-12):
            return None
        return (f"the heater's window [{w.min_V:g}, {w.max_V:.9g}] V reaches beyond the instrument's full scale of "
                f"+-{fs:g} V: lower [heater] max_V (or max_current_mA) to fit it")
