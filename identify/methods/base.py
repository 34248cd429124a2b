"""The shape every identification method shares (scikit-learn conventions).

The constructor holds settings only; :meth:`Method.fit` takes a
:class:`~identify.methods.problem.Problem`, learns, and sets the fitted
attributes (ending in ``_``):

``parameters_`` ``(P,)`` the vector ``w`` (with extra columns, in the
order of :class:`~identify.operators.AugmentedOperator`); ``model_`` the
:class:`~identify.model.PreisachModel` of its equation (22) part; ``seconds_`` wall time of the fit;
``info_`` solver diagnostics (status, iterations, ...).

A small problem is solved with one BLAS thread (:mod:`identify.threads`).

Every method has the setting ``solver``: ``"fast"`` (the default) uses the
matrix-free operator and the structured solvers, ``"dense"`` the dense
reference formulation (dense ``S``, cvxpy with Clarabel, scipy's NNLS) --
kept to check the fast path against (``rig bench``).
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from ..errors import IdentifyError, MethodNotApplicable
from ..model import PreisachModel
from ..threads import blas_threads_for
from .problem import Problem

#: The values of every method's ``solver`` setting.
SOLVERS = ("fast", "dense")


class Method(ABC):
    """Base class of the identification methods."""

    #: Name used by the command line and in reports.
    name: ClassVar[str]
    #: Needs a square design whose ``S`` is invertible (the damped oscillation, with a thermal point).
    needs_square: ClassVar[bool] = False
    #: Needs the order of all outputs (the 'CS Order' assumption).
    needs_order: ClassVar[bool] = False
    #: Needs inputs made of first-order reversal curves (``problem.curves``).
    needs_curves: ClassVar[bool] = False
    #: Its name in the paper's figures (the study's legends); default: :attr:`name`.
    label: ClassVar[str | None] = None
    #: Fast enough to fit again while a run goes on (``rig watch``), on the points measured so far.
    refits_live: ClassVar[bool] = False

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        """A rough model of a fit's own time (s) and working memory (bytes) with ``parameters`` ``P``,
        ``points`` applied ``n`` and ``measured`` rows ``M``, beyond the per-parameter and per-point arrays
        every fit has; ``square``: the inputs are the square damped-oscillation design.

        What ``rig identify`` checks against its limits before a fit starts (:mod:`rig.budget`): good to a
        factor of ten in time and three in memory.  The constants of each method's model come from measured
        fits (``benchmarks/identify_cost.py``).  Default: the size of ``A S``.
        """
        return 1e-6 * measured * parameters, 8.0 * measured * parameters

    def __init__(self, solver: str = "fast") -> None:
        if solver not in SOLVERS:
            raise IdentifyError(f"unknown solver {solver!r}; choose from {', '.join(SOLVERS)}")
        self.solver = solver

    @property
    def dense(self) -> bool:
        """Whether this fit uses the dense reference formulation (``solver="dense"``)."""
        return getattr(self, "solver", "fast") == "dense"

    def fit(self, problem: Problem) -> "Method":
        """Identify a model from ``problem``; returns ``self``."""
        if problem.n_measured > problem.n_rows:
            raise IdentifyError(
                f"M={problem.n_measured} measurements exceed the N={problem.n} applied inputs"
            )
        dense = self.dense
        start = time.perf_counter()
        if self.needs_square:
            try:
                # square and invertible, checked numerically by the path that will solve with S;
                # raises MethodNotApplicable with the reason
                problem.require_square("dense" if dense else "fast")
            except MethodNotApplicable as exc:
                raise MethodNotApplicable(f"{self.name} {exc}") from None
        if self.needs_order:
            problem.require_order(self.name)
        with blas_threads_for(problem.n_parameters):  # one BLAS thread for a small problem
            w, info = self._solve(problem)
        self.seconds_ = time.perf_counter() - start
        w = np.asarray(w, dtype=float)
        if not np.all(np.isfinite(w)):
            raise IdentifyError(f"{self.name} produced non-finite parameters")
        self.parameters_ = w
        self.info_ = info
        base, _ = problem.split(w)
        self.model_ = PreisachModel.from_parameters(problem.grid, base, problem.thermal_term)
        return self

    @abstractmethod
    def _solve(self, problem: Problem) -> tuple[np.ndarray, dict[str, Any]]:
        """Return the parameter vector ``w`` and solver diagnostics."""

    def settings(self) -> dict[str, Any]:
        """Constructor settings (stored with identified models)."""
        return {k: v for k, v in vars(self).items() if not k.endswith("_")}

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.settings().items())
        return f"{type(self).__name__}({args})"
