"""Inverse hysteresis compensation: the heater voltage that makes a model's output follow a target.

One module, one job:

* :mod:`~identify.inverse.path` -- the Preisach part along a monotone move
  from the present memory curve: a quadratic of the input between two walls
  and two corners;
* :mod:`~identify.inverse.roots` -- real roots of a low-order polynomial on
  an interval (and where it comes closest to zero);
* :mod:`~identify.inverse.effects` -- how each fitted effect enters the
  inversion, or why it cannot;
* :mod:`~identify.inverse.inverter` -- :class:`Inverter` (one target at a
  time: the choice rule, unreachable targets, the memory advanced as the
  forward model does) and :func:`invert` (a whole sequence);
* :mod:`~identify.inverse.loop` -- the major loop: the model's output range
  and the linear inverse practitioners start from;
* :mod:`~identify.inverse.feedback` -- PI and iterative learning control in
  output space, around the inverse.

Pure numerics: arrays in, arrays and result objects out.
"""

from .effects import NotInvertible
from .feedback import FEEDBACKS, ILC, PI, Feedback, NoFeedback, make_feedback, period_of
from .inverter import InverseResult, Inverter, Step, invert
from .loop import LinearInverse, major_loop, output_range

__all__ = [
    "FEEDBACKS",
    "ILC",
    "PI",
    "Feedback",
    "InverseResult",
    "Inverter",
    "LinearInverse",
    "NoFeedback",
    "NotInvertible",
    "Step",
    "invert",
    "major_loop",
    "make_feedback",
    "output_range",
    "period_of",
]
