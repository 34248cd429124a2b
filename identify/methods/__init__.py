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
from .base import Method
from .compressive import CompressiveSensing, CompressiveSensingNoDCT, CompressiveSensingOrder
from .forc_everett import EverettFORC
from .least_squares import LeastSquares
from .ordered_nn import CompressiveSensingOrderNonNegative
from ..sampling import choose_rows
from .problem import Problem
from .smooth_nn import SmoothNonNegative

METHODS: dict[str, type[Method]] = {
    cls.name: cls
    for cls in (
        LeastSquares,
        CompressiveSensing,
        CompressiveSensingOrder,
        CompressiveSensingOrderNonNegative,
        CompressiveSensingNoDCT,
        SmoothNonNegative,
        EverettFORC,
    )
}


#: The methods that apply to the damped oscillation (all but those that need curves).
DAMPED_METHODS: tuple[str, ...] = tuple(name for name, cls in METHODS.items() if not cls.needs_curves)


def make_method(name: str, **settings: Any) -> Method:
    """A method instance by name; unknown names raise :class:`IdentifyError`."""
    try:
        cls = METHODS[name]
    except KeyError:
        raise IdentifyError(
            f"unknown method {name!r}; choose from {', '.join(METHODS)}"
        ) from None
    return cls(**settings)


__all__ = ["DAMPED_METHODS", "METHODS", "Method", "Problem", "choose_rows", "make_method"]
