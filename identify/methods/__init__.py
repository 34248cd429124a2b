"""Identification methods, by the names the command line uses.

=============== ======================================== ====================
name            paper                                    needs
=============== ======================================== ====================
``ls``          'Least Squares' (lsqnonneg)              any input history
``cs``          'CS', equations (12)-(15)                damped oscillation
``cs_order``    'CS Order', equation (16)                damped osc. + order
``cs_order_nn`` 'CS Order Non-negative', equation (17)   damped osc. + order
``cs_nodct``    'CS Without DCT', figure 4(a)            damped oscillation
``smooth_nn``   ours: NNLS + roughness penalty, GCV      any input history
``everett``     Mayergoyz: second differences of FORCs   first-order reversal
                                                         curves
=============== ======================================== ====================
"""

from __future__ import annotations

from typing import Any

from ..errors import IdentifyError
from ..registry import ByName
from ..sampling import choose_rows
from .base import Method
from .compressive import CompressiveSensing, CompressiveSensingNoDCT, CompressiveSensingOrder
from .forc_everett import EverettFORC
from .least_squares import LeastSquares
from .ordered_nn import CompressiveSensingOrderNonNegative
from .problem import Problem
from .smooth_nn import SmoothNonNegative

#: The methods, in the order the command line and the study list them: the registry (one line per method).
#: Each class says what it needs (:attr:`Method.needs_square`, :attr:`Method.needs_order`,
#: :attr:`Method.needs_curves`), what a fit costs (:meth:`Method.cost`), its name in the paper's figures
#: and whether ``rig watch`` may refit with it.
METHOD_CLASSES: tuple[type[Method], ...] = (
    LeastSquares,
    CompressiveSensing,
    CompressiveSensingOrder,
    CompressiveSensingOrderNonNegative,
    CompressiveSensingNoDCT,
    SmoothNonNegative,
    EverettFORC,
)
#: The methods by name (:data:`METHOD_CLASSES`, read at each use).
METHODS: ByName[type[Method]] = ByName(lambda: METHOD_CLASSES)
#: The methods that apply to the damped oscillation (all but those that need curves), by name.
DAMPED_METHODS: ByName[type[Method]] = ByName(lambda: tuple(c for c in METHOD_CLASSES if not c.needs_curves))
#: The methods ``rig watch`` may refit with while a run goes on, by name.
LIVE_METHODS: ByName[type[Method]] = ByName(lambda: tuple(c for c in METHOD_CLASSES if c.refits_live))


def make_method(name: str, **settings: Any) -> Method:
    """A method instance by name; unknown names raise :class:`IdentifyError`."""
    try:
        cls = METHODS[name]
    except KeyError:
        raise IdentifyError(
            f"unknown method {name!r}; choose from {', '.join(METHODS)}"
        ) from None
    return cls(**settings)


__all__ = ["DAMPED_METHODS", "LIVE_METHODS", "METHODS", "METHOD_CLASSES", "Method", "Problem", "choose_rows", "make_method"]
