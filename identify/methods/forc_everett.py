"""'Everett': Mayergoyz's identification from first-order reversal curves.

The classical identification FORC practitioners use (Mayergoyz 1986;
Pike, Roberts and Verosub 1999): the cell weights are second differences
of the measured FORC surface, so each cell is determined by the curves
around it and nothing is solved globally (:mod:`identify.forc`)::

    mu_ij = -1/2 [u(v_j, v_i) - u(v_{j+1}, v_i) - u(v_j, v_{i+1}) + u(v_{j+1}, v_{i+1})],   j < i

with ``u(r, x)`` the output measured at input ``x`` on the curve reversed
at ``r``, interpolated at the grid's walls.  Three choices complete it:

* **Bias and thermal term.**  ``mu0 + c_d x`` cancels in every second
  difference, so the off-diagonal cells do not depend on it.  The diagonal
  cells do not have a second difference: their signed area changes only
  within one cell of a curve's reversal, exactly where the reversible
  ``c_d x`` term acts too (on the walls the two are the same column).  So
  the diagonal cells, ``mu0`` and ``c_d`` are fitted by least squares on the
  measured rows with the off-diagonal cells fixed -- ``L + 2`` unknowns,
  diagonal cells >= 0 (the reversible part of a loop rises with the input).
* **The density's sign.**  The second differences keep their sign:
  negative regions of a FORC diagram are real for interacting particles,
  and the classical method does not constrain them (``nonnegative=True``
  sets them to zero instead).
* **Where no curve reaches** (above the highest reversal input, beyond
  the end of the curves) a cell's corners are unknown and its weight is 0:
  no data, no hysterons.

Needs inputs made of first-order reversal curves from positive saturation
(``problem.curves``, from a session imported from a FORC measurement); any
other input raises :class:`MethodNotApplicable` saying so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..forc import everett_cells, forc_surface, reversal_curves
from .base import Method
from .nnls import nnls_free
from .problem import Problem


class EverettFORC(Method):
    """Second differences of the FORC surface; ``nonnegative`` clips negative cells to 0."""

    name = "everett"
    needs_curves = True

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        """Second differences of the interpolated FORC surface."""
        return 1e-6 * points + 1e-5 * parameters, 8.0 * points

    def __init__(self, nonnegative: bool = False, solver: str = "fast") -> None:
        super().__init__(solver)  # both solvers take the same path: second differences, one small fit
        self.nonnegative = bool(nonnegative)

    def _solve(self, problem: Problem) -> tuple[np.ndarray, dict[str, Any]]:
        grid = problem.grid
        curves = reversal_curves(grid, problem.inputs, problem.curves, problem.rows, problem.measured, self.name)
        problem.require_thermal_identifiable(self.name)
        mu, known = everett_cells(grid, forc_surface(curves, grid))
        negative = mu < 0
        info: dict[str, Any] = {
            "curves": len(curves),
            "cells_from_curves": int(known.sum()),
            "cells_unreached": int(np.count_nonzero(~known & (grid.cell_alpha > grid.cell_beta))),
            "negative_cells": int(negative.sum()),
            "negative_mass": float(mu[negative].sum()),
        }
        if self.nonnegative:
            mu[negative] = 0.0
        w, fit_info = _fit_diagonal(problem, mu)
        return w, {**info, **fit_info}


def _fit_diagonal(problem: Problem, mu: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
    """``w`` with the off-diagonal cells ``mu`` and the diagonal cells, ``mu0`` (and ``c_d``) fitted.

    Least squares on the measured rows of ``y - S_off mu`` against the
    diagonal cells' columns (>= 0) and the free columns -- with extra
    columns (effect terms, :mod:`identify.effects`) those too, so
    ``everett`` fits effects jointly with the diagonal of the density
    (the off-diagonal cells come from the curves' second differences).
    """
    grid = problem.grid
    n, P = grid.n_cells, problem.n_parameters
    diag = np.flatnonzero(grid.cell_alpha == grid.cell_beta)
    w = np.zeros(P)
    w[:n] = mu
    rows = problem.rows
    fixed = np.asarray(problem.operator.matvec(w)).ravel()[rows]
    pick = np.zeros((P, diag.size + P - n))
    pick[diag, np.arange(diag.size)] = 1.0
    pick[n:, diag.size:] = np.eye(P - n)
    columns = np.asarray(problem.operator.matmat(pick))[rows]
    fitted, info = nnls_free(columns, problem.measured - fixed, diag.size + problem.extra_nonneg)
    w[diag] = fitted[: diag.size]
    w[n:] = fitted[diag.size:]
    return w, {"diagonal_residual_norm": info["residual_norm"]}
