"""The discretised Preisach model with bias and thermal term, equation (22), and its effects.

``u(n) = mu0 + c_d v(n) + sum_ij mu_ij s_ij(n)``

with ``u`` the deflection (um), ``v`` the heater voltage (V), ``mu_ij`` the
weight of cell ``(i, j)`` (um; the paper's density value of the cell, i.e.
density times cell area, since ``s_ij`` is normalised to [-1, 1]), ``mu0``
the bias (um) and ``c_d`` the linear thermal coefficient (um/V).

A model may carry fitted effects (:mod:`identify.effects`): terms beside
equation (22) that act on a whole recorded run (its inputs, time stamps,
dwells) -- :meth:`PreisachModel.predict_run`.  Without effects a model is
exactly equation (22) and reads and writes exactly as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import forward
from .effects import Effect, effect_from_dict, effect_to_dict, pipeline_order
from .effects.compose import predict_run
from .errors import IdentifyError
from .grid import Grid
from .memory import InitialState
from .regressor import n_parameters

#: Version of the JSON-safe dictionary written by :meth:`PreisachModel.to_dict`.
MODEL_FORMAT = 1


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

    def predict_run(self, run: Any) -> np.ndarray:
        """The reading (um) at every point of ``run`` (an :class:`identify.runs.Run`), ``(n,)``, with
        the model's effects, from negative saturation.

        Raises :class:`identify.effects.EffectNotApplicable` when the run
        lacks what an effect needs (time stamps for ``creep``, ...).
        """
        return predict_run(self, run)

    def without_effects(self) -> "PreisachModel":
        """This model's equation (22) part."""
        return replace(self, effects=()) if self.effects else self

    def state(self, initial: InitialState = "negative", history: np.ndarray | None = None) -> "forward.HysteresisState":
        """The model with its memory, to be stepped one input at a time."""
        return forward.HysteresisState(self, initial, history)

    # ------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (read back by :meth:`from_dict`)."""
        return {
            "format": MODEL_FORMAT,
            "levels": self.grid.levels,
            "v_min": self.grid.v_min,
            "v_max": self.grid.v_max,
            "walls": [float(x) for x in self.grid.walls],
            "mu0": self.mu0,
            "c_d": self.c_d,
            "density": self.density_matrix().tolist(),
            "input_unit": self.input_unit,
            "output_unit": self.output_unit,
            **({"metadata": self.metadata} if self.metadata else {}),
            **({"effects": [effect_dict(e) for e in self.effects]} if self.effects else {}),
        }

    @classmethod
    def from_dict(cls, data: Any) -> "PreisachModel":
        """Read a model written by :meth:`to_dict` (or ``rig identify --json``)."""
        if not isinstance(data, dict):
            raise IdentifyError("model must be a JSON object")
        missing = [k for k in ("walls", "mu0", "c_d", "density") if k not in data]
        if missing:
            raise IdentifyError(f"model is missing the key(s) {', '.join(missing)}")
        fmt = data.get("format", MODEL_FORMAT)
        if not isinstance(fmt, int) or fmt > MODEL_FORMAT:
            raise IdentifyError(f"model format {fmt!r} is newer than this program understands")
        try:
            walls = np.asarray(data["walls"], dtype=float)
            density = np.asarray(data["density"], dtype=float)
            mu0, c_d = float(data["mu0"]), float(data["c_d"])
        except (TypeError, ValueError) as exc:
            raise IdentifyError(f"model has a non-numeric value: {exc}") from None
        if walls.ndim != 1 or walls.size < 2 or not np.all(np.isfinite(walls)):
            raise IdentifyError("model 'walls' must be a list of at least 2 finite numbers")
        levels = walls.size - 1
        if "levels" in data and data["levels"] != levels:
            raise IdentifyError(
                f"model says levels={data['levels']!r} but has {walls.size} walls"
            )
        grid = Grid(levels, walls[0], walls[-1])
        if not np.allclose(walls, grid.walls, rtol=0, atol=1e-9 * (grid.v_max - grid.v_min)):
            raise IdentifyError("model walls are not uniformly spaced")
        for key, wall in (("v_min", walls[0]), ("v_max", walls[-1])):
            said = data.get(key)
            if said is not None and not (isinstance(said, (int, float)) and abs(said - wall) <= 1e-9 * abs(walls[-1] - walls[0])):
                raise IdentifyError(f"model says {key}={said!r} but its walls {'start' if key == 'v_min' else 'end'} at "
                                    f"{wall:g}: the model contradicts itself (edited by hand?)")
        if density.shape != (levels, levels):
            raise IdentifyError(
                f"model 'density' must be a {levels}x{levels} list of lists, got shape {density.shape}"
            )
        if not np.all(np.isfinite(density)):
            raise IdentifyError("model 'density' has non-finite values")
        effects = data.get("effects", [])
        if not isinstance(effects, list):
            raise IdentifyError("model 'effects' must be a list of {\"name\", \"params\"} objects")
        if effects:
            effects = pipeline_order(effect_from_dict(e) for e in effects)
        return cls(
            grid,
            grid.density_vector(density),
            mu0,
            c_d,
            input_unit=str(data.get("input_unit", "V")),
            output_unit=str(data.get("output_unit", "um")),
            metadata=dict(data.get("metadata", {})),
            effects=tuple(effects),
        )


def effect_dict(effect: Effect) -> dict[str, Any]:
    """An effect's stored form, ``{"name", "params"}``."""
    return effect_to_dict(effect)
