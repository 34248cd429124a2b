"""Preisach hysteresis identification (Zhang, Torres, Sepulveda, Tan 2016).

Pure numerical code: arrays in, arrays and result objects out; no files,
no printing.  Modules:

* :mod:`identify.grid` -- walls, cells and their numbering;
* :mod:`identify.memory` -- the memory curve and exact signed areas;
* :mod:`identify.regressor` -- the regressor matrix ``S`` of equation (22);
* :mod:`identify.everett` -- the Everett function and a memory curve's Everett terms;
* :mod:`identify.operators` -- ``S`` as a matrix-free operator;
* :mod:`identify.square` -- sparse solves and the sparse inverse of the square design;
* :mod:`identify.regressor_design` -- the design (grid, inputs, thermal term, initial memory) as a value that
  owns its operator and square solver;
* :mod:`identify.model` -- :class:`PreisachModel`;
* :mod:`identify.forward` -- the fast forward model (whole sequences, or step by step);
* :mod:`identify.excitation` -- the damped oscillation and random inputs;
* :mod:`identify.dct` -- the orthonormal DCT ``Psi``;
* :mod:`identify.methods` -- the identification methods.
"""

from .errors import IdentifyError, MethodNotApplicable
from .excitation import Excitation, damped_oscillation, random_input, thermal_point
from .grid import Grid
from .memory import MemoryCurve, signed_areas
from .methods import METHODS, Method, Problem, choose_rows, make_method
from .model import PreisachModel
from .regressor import memory_states, regressor_matrix

__all__ = [
    "METHODS",
    "Excitation",
    "Grid",
    "IdentifyError",
    "MemoryCurve",
    "Method",
    "MethodNotApplicable",
    "PreisachModel",
    "Problem",
    "choose_rows",
    "damped_oscillation",
    "make_method",
    "memory_states",
    "random_input",
    "regressor_matrix",
    "signed_areas",
    "thermal_point",
]
