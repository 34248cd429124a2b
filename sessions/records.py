"""Plain records stored in a session: the excitation plan, quantities, events."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from identify import Excitation, Grid

from .errors import DataFileError
from .schema import DEFAULT_QUANTITIES, Status


@dataclass(frozen=True, eq=False)
class ExcitationRecord:
    """What the session applies: the planned inputs and which of them are measured.

    ``inputs`` has shape ``(N,)`` (input unit); ``measure`` is a bool array of
    the same shape (compressive acquisition applies every point but measures
    only some).  ``levels``/``v_min``/``v_max`` describe the grid the
    excitation was built on, or are ``None`` when unknown (e.g. an imported
    trace without ``--levels``).  ``dwell`` describes the dwell policy
    (``{"policy": "fixed", "seconds": 5}``, ...); ``extra`` holds anything
    else the producer wants kept (a source file, a random-input length).
    ``curves`` ``(N,)`` (optional) numbers the curve each point belongs to,
    ``-1`` for points on none (a FORC protocol's saturation and calibration
    points); ``None`` when the excitation is not made of curves.
    ``targets`` ``(N,)`` (optional; output unit) is the output each point is
    meant to reach (a tracking run, ``rig track``); ``None`` otherwise.
    """

    kind: str
    inputs: np.ndarray
    measure: np.ndarray | None = None
    levels: int | None = None
    v_min: float | None = None
    v_max: float | None = None
    thermal_term: bool = False
    seed: int | None = None
    dwell: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    curves: np.ndarray | None = None
    targets: np.ndarray | None = None

    def __post_init__(self) -> None:
        v = np.array(self.inputs, dtype=float).reshape(-1)
        if not np.all(np.isfinite(v)):
            raise DataFileError("excitation inputs must be finite")
        m = np.ones(v.shape, bool) if self.measure is None else np.array(self.measure, dtype=bool).reshape(-1)
        if m.shape != v.shape:
            raise DataFileError(f"measure plan has {m.size} entries for {v.size} inputs")
        v.flags.writeable = False
        m.flags.writeable = False
        object.__setattr__(self, "inputs", v)
        object.__setattr__(self, "measure", m)
        if self.curves is not None:
            c = np.array(self.curves).reshape(-1)
            if c.shape != v.shape:
                raise DataFileError(f"curve index has {c.size} entries for {v.size} inputs")
            if c.size and not np.issubdtype(c.dtype, np.integer):
                raise DataFileError("curve index must be whole numbers")
            c = c.astype(np.int64)
            if np.any(c < -1):
                raise DataFileError("curve index must be >= -1 (-1: on no curve)")
            c.flags.writeable = False
            object.__setattr__(self, "curves", c)
        if self.targets is not None:
            y = np.array(self.targets, dtype=float).reshape(-1)
            if y.shape != v.shape:
                raise DataFileError(f"targets have {y.size} entries for {v.size} inputs")
            if not np.all(np.isfinite(y)):
                raise DataFileError("excitation targets must be finite")
            y.flags.writeable = False
            object.__setattr__(self, "targets", y)
        if self.levels is not None:
            grid = Grid(self.levels, self.v_min, self.v_max)  # validates
            object.__setattr__(self, "levels", grid.levels)
            object.__setattr__(self, "v_min", grid.v_min)
            object.__setattr__(self, "v_max", grid.v_max)

    @classmethod
    def from_excitation(
        cls, excitation: Excitation, measure: np.ndarray | None = None, dwell: dict[str, Any] | None = None
    ) -> "ExcitationRecord":
        """The record of an :class:`identify.Excitation` with a measurement plan."""
        g = excitation.grid
        return cls(
            kind=excitation.kind,
            inputs=excitation.inputs,
            measure=measure,
            levels=g.levels,
            v_min=g.v_min,
            v_max=g.v_max,
            thermal_term=excitation.thermal_term,
            seed=excitation.seed,
            dwell=dict(dwell or {}),
            extra=dict(excitation.extra),
        )

    @property
    def n_points(self) -> int:
        return int(self.inputs.size)

    @property
    def grid(self) -> Grid | None:
        """The grid of the excitation, or ``None`` when not recorded."""
        return None if self.levels is None else Grid(self.levels, self.v_min, self.v_max)


@dataclass(frozen=True, eq=False)
class CalibrationRecord:
    """Drift-monitor measurements: the output measured again and again at one fixed input.

    Arrays ``(K,)``: ``t_s`` (s since the start), ``input`` and ``output``
    (as measured, never corrected), ``curve`` (the curve each precedes) and
    ``row`` (the ``/samples`` row of the applied point it was measured at).
    ``drift_correction`` describes the correction applied to the session's
    outputs from these points (``None``: the outputs are as measured).
    """

    t_s: np.ndarray
    input: np.ndarray
    output: np.ndarray
    curve: np.ndarray
    row: np.ndarray
    drift_correction: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        n = {np.asarray(getattr(self, k)).size for k in ("t_s", "input", "output", "curve", "row")}
        if len(n) != 1:
            raise DataFileError("calibration columns have different lengths")

    def __len__(self) -> int:
        return int(np.asarray(self.t_s).size)


@dataclass(frozen=True)
class Quantities:
    """Names and units of the input, the output and the raw sensor signal."""

    input_quantity: str = DEFAULT_QUANTITIES["input_quantity"]
    input_unit: str = DEFAULT_QUANTITIES["input_unit"]
    output_quantity: str = DEFAULT_QUANTITIES["output_quantity"]
    output_unit: str = DEFAULT_QUANTITIES["output_unit"]
    raw_quantity: str = DEFAULT_QUANTITIES["raw_quantity"]
    raw_unit: str = DEFAULT_QUANTITIES["raw_unit"]

    def to_attrs(self) -> dict[str, str]:
        return dict(vars(self))


@dataclass(frozen=True)
class Event:
    """One row of the session log."""

    t_unix: float
    n_samples: int
    status: Status
    event: str
    message: str = ""


@dataclass(frozen=True)
class IdentifyRecipe:
    """How a session wants to be identified: what ``rig identify SESSION`` does when not told otherwise.

    ``method`` names an identification method (``ls``, ``smooth_nn``, ...);
    ``levels``, ``v_min`` and ``v_max`` the grid (``None``: the default --
    the session's excitation grid, else the measured inputs' range);
    ``effects`` the effects to fit with the density (``NAME[:OPTION]``, as
    ``rig identify --with``); ``thermal_term`` whether to fit ``c_d v``;
    ``reason`` says, for a person, why this recipe.  Stored as the JSON root
    attribute ``identify_recipe`` (``docs/sessions.md``); the method and
    effect names are checked when the recipe is used, not when it is read,
    so that a session naming a method this version does not know still reads.
    """

    method: str = "ls"
    levels: int | None = None
    v_min: float | None = None
    v_max: float | None = None
    effects: tuple[str, ...] = ()
    thermal_term: bool = True
    reason: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.method, str) or not self.method.strip():
            raise DataFileError(f"identification recipe: method must be a method's name, got {self.method!r}")
        if self.levels is not None and (isinstance(self.levels, bool) or not isinstance(self.levels, int)
                                        or self.levels < 1):
            raise DataFileError(f"identification recipe: levels must be a whole number >= 1, got {self.levels!r}")
        for key in ("v_min", "v_max"):
            x = getattr(self, key)
            if x is None:
                continue
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise DataFileError(f"identification recipe: {key} must be a finite number, got {x!r}")
            object.__setattr__(self, key, float(x))
        if self.v_min is not None and self.v_max is not None and not self.v_max > self.v_min:
            raise DataFileError(f"identification recipe: needs v_max > v_min, got [{self.v_min}, {self.v_max}]")
        effects = self.effects
        if isinstance(effects, str) or not all(isinstance(e, str) and e.strip() for e in effects):
            raise DataFileError(f"identification recipe: effects must be a list of effect names, got {effects!r}")
        object.__setattr__(self, "effects", tuple(e.strip() for e in effects))
        if not isinstance(self.thermal_term, bool):
            raise DataFileError(f"identification recipe: thermal_term must be true or false, got {self.thermal_term!r}")
        if not isinstance(self.reason, str):
            raise DataFileError(f"identification recipe: reason must be text, got {self.reason!r}")

    def to_dict(self) -> dict[str, Any]:
        """The stored form: ``{"method", "levels", "v_min", "v_max", "effects", "thermal_term", "reason"}``."""
        return {"method": self.method, "levels": self.levels, "v_min": self.v_min, "v_max": self.v_max,
                "effects": list(self.effects), "thermal_term": self.thermal_term, "reason": self.reason}

    @classmethod
    def from_dict(cls, data: Any) -> "IdentifyRecipe":
        """The recipe of its stored form (keys this version does not know are ignored; missing ones take
        the defaults); :class:`DataFileError` when malformed."""
        if not isinstance(data, dict):
            raise DataFileError(f"identification recipe must be a JSON object, got {type(data).__name__}")
        known = {k: data[k] for k in cls.__dataclass_fields__ if k in data}
        if "effects" in known:
            if not isinstance(known["effects"], list):
                raise DataFileError(f"identification recipe: effects must be a list of effect names, "
                                    f"got {known['effects']!r}")
            known["effects"] = tuple(known["effects"])
        return cls(**known)
