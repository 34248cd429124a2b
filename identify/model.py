"""The discretised Preisach model with bias and thermal term, equation (22), and its effects.

``u(n) = mu0 + c_d v(n) + sum_ij mu_ij s_ij(n)``

with ``u`` the deflection (um), ``v`` the heater voltage (V), ``mu_ij`` the
weight of cell ``(i, j)`` (um; the paper's density value of the cell, i.e.
density times cell area, since ``s_ij`` is normalised to [-1, 1]), ``mu0``
the bias (um) and ``c_d`` the linear thermal coefficient (um/V).

A model may carry fitted effects (:mod:`identify.effects`): terms beside
equation (22) that act on a whole recorded run (its inputs, time stamps,
dwells) -- :meth:`PreisachModel.predict_run`.  Without effects a model is
exactly equation (22) and reads and writes exactly as before.  Its JSON form
(model files, ``rig identify --json``, sessions) is :mod:`identify.model_json`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import forward
from .effects import Effect
from .effects.compose import FixedPointMemo, predict_run
from .errors import IdentifyError
from .grid import Grid
from .memory import InitialState
from .regressor import n_parameters

@dataclass(frozen=True, eq=False)
class PreisachModel:
    """A Preisach model on ``grid`` with cell weights ``density`` (um).

    ``density`` has shape ``(n_cells,)`` in the paper's parameter order
    (:mod:`identify.grid`); use :meth:`density_matrix` for the ``(L, L)``
    view indexed ``[i, j]``.
    """

    grid: Grid
    density: np.ndarray
    mu0: float = 0.0
    c_d: float = 0.0
    input_unit: str = "V"
    output_unit: str = "um"
    metadata: dict[str, Any] = field(default_factory=dict, compare=False)
    #: Fitted effects (:class:`identify.effects.Effect`), in the order they act; () for equation (22) alone.
    effects: tuple[Effect, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        d = np.array(self.density, dtype=float)
        if d.shape != (self.grid.n_cells,):
            raise IdentifyError(
                f"density has shape {d.shape}, expected ({self.grid.n_cells},) for L={self.grid.levels}"
            )
        if not np.all(np.isfinite(d)):
            raise IdentifyError("density has non-finite values")
        for name in ("mu0", "c_d"):
            val = float(getattr(self, name))
            if not math.isfinite(val):
                raise IdentifyError(f"{name} is not finite ({val})")
            object.__setattr__(self, name, val)
        d.flags.writeable = False
        object.__setattr__(self, "density", d)
        effects = tuple(self.effects)
        if any(not getattr(e, "fitted", False) for e in effects):
            raise IdentifyError("a model's effects must be fitted")
        object.__setattr__(self, "effects", effects)

    # ------------------------------------------------------------ parameters
    def parameters(self, thermal_term: bool = True) -> np.ndarray:
        """The parameter vector ``w`` = (cells, mu0[, c_d])."""
        tail = [self.mu0, self.c_d] if thermal_term else [self.mu0]
        return np.concatenate([self.density, tail])

    @classmethod
    def from_parameters(
        cls, grid: Grid, w: np.ndarray, thermal_term: bool, **kwargs: Any
    ) -> "PreisachModel":
        """Inverse of :meth:`parameters`."""
        w = np.asarray(w, dtype=float)
        if w.shape != (n_parameters(grid, thermal_term),):
            raise IdentifyError(
                f"parameter vector has shape {w.shape}, expected ({n_parameters(grid, thermal_term)},)"
            )
        c = grid.n_cells
        return cls(
            grid, w[:c], float(w[c]), float(w[c + 1]) if thermal_term else 0.0, **kwargs
        )

    def density_matrix(self) -> np.ndarray:
        """``(L, L)`` matrix of cell weights ``[i, j]`` (zero above the diagonal)."""
        return self.grid.density_matrix(self.density)

    # ------------------------------------------------------------ prediction
    def predict(
        self,
        inputs: np.ndarray,
        initial: InitialState = "negative",
        history: np.ndarray | None = None,
    ) -> np.ndarray:
        """Model output (um) for an input sequence (V), shape ``(n,)``.

        The memory starts in the ``initial`` saturation, then sees
        ``history`` (not returned); inputs beyond the grid range saturate.
        Uses the Everett function of the density (:mod:`identify.forward`):
        ``O(n + L^2)`` time and memory.  For one input at a time (inverse
        compensation) use :meth:`state`.  The model's effects are left out:
        they act on a whole run (:meth:`predict_run`).
        """
        return forward.predict(self, inputs, initial, history)

    def predict_many(self, inputs: np.ndarray) -> np.ndarray:
        """:meth:`predict` of each row of ``inputs`` ``(k, n)`` (V) from negative saturation, ``(k, n)`` (um):
        the same numbers, the replays batched (:func:`identify.forward.predict_many`)."""
        return forward.predict_many(self, inputs)

    def predict_run(self, run: Any, memo: FixedPointMemo | None = None) -> np.ndarray:
        """The reading (um) at every point of ``run`` (an :class:`identify.runs.Run`), ``(n,)``, with
        the model's effects, from negative saturation.  ``memo``: an
        :class:`identify.effects.compose.FixedPointMemo` for many runs that share their beginning (the
        same numbers).

        Raises :class:`identify.effects.EffectNotApplicable` when the run
        lacks what an effect needs (time stamps for ``creep``, ...).
        """
        return predict_run(self, run, memo=memo)

    def without_effects(self) -> "PreisachModel":
        """This model's equation (22) part."""
        return replace(self, effects=()) if self.effects else self

    def state(self, initial: InitialState = "negative", history: np.ndarray | None = None) -> "forward.HysteresisState":
        """The model with its memory, to be stepped one input at a time."""
        return forward.HysteresisState(self, initial, history)
