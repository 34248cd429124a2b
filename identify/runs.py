"""A recorded run as the effects and the diagnosis see it, and what it derives from its input history.

A :class:`Run` holds every applied point of one acquisition run -- the
memory state of each point depends on all before it -- with its time
stamps and dwells.  :class:`History` derives the quantities the candidates
and the residual bins use: the branch of every point, its reversals, the
time since the last reversal, the last step.  Reversals follow
:func:`identify.acquisition_plan.reversal_points` (a run starts from
negative saturation), so the diagnosis and the sequencer agree on them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from .acquisition_plan import reversal_points
from .branch import COOLING, HEATING, branches
from .errors import IdentifyError
from .regressor import check_inputs

#: Branch code of the first point after a reversal (:attr:`History.branch`; heating and cooling as
#: :mod:`identify.branch`).
AFTER_REVERSAL = 0
BRANCH_NAMES = {HEATING: "heating", COOLING: "cooling", AFTER_REVERSAL: "first step after a reversal"}


@dataclass(frozen=True, eq=False)
class Run:
    """One acquisition run; arrays have shape ``(n,)``, one entry per applied point.

    ``inputs`` (V) every applied point, in order; ``outputs`` (um) NaN where
    the point was applied but not measured; ``t_s`` (s) time of the
    readings since the start of the run; ``dwell_s`` (s) time from the
    set-point to the readings (NaN when unknown: the set-point is then
    taken to be at ``t_s``).  ``readings`` is the number of sensor readings
    averaged per measurement (None when unknown).  ``initial_V`` is the
    input the run started from (the sequencer saturates at 0 V).

    ``input_unit``/``output_unit`` name the run's units (the VO2 rig's V
    and um by default; an imported FORC measurement's T and A m^2): every
    "V" and "um" of the diagnosis means these.  ``by_curves`` marks a run
    made of curves (first-order reversal curves), whose residual is also
    binned by the reversal input of every point.  ``timed`` is False when
    the run's times carry no information (all equal): effects of time are
    then not applicable.
    """

    name: str
    inputs: np.ndarray
    outputs: np.ndarray
    t_s: np.ndarray
    dwell_s: np.ndarray
    readings: int | None = None
    initial_V: float = 0.0
    input_unit: str = "V"
    output_unit: str = "um"
    by_curves: bool = False

    @property
    def timed(self) -> bool:
        """Whether the run's time stamps say anything (they are not all equal)."""
        return bool(self.t_s.size > 1 and self.t_s[-1] > self.t_s[0])

    @property
    def has_dwell(self) -> bool:
        """Whether any point's dwell (set-point to readings) is known."""
        return bool(np.any(np.isfinite(self.dwell_s)))

    def __post_init__(self) -> None:
        v = check_inputs(self.inputs, f"{self.name}: input")
        arrays = {"outputs": self.outputs, "t_s": self.t_s, "dwell_s": self.dwell_s}
        for key, value in arrays.items():
            a = np.asarray(value, dtype=float).reshape(-1)
            if a.shape != v.shape:
                raise IdentifyError(f"{self.name}: {a.size} values of {key} for {v.size} inputs")
            object.__setattr__(self, key, a)
        object.__setattr__(self, "inputs", v)
        if not np.all(np.isfinite(self.t_s)):
            raise IdentifyError(f"{self.name}: the time stamps must be finite")
        if np.any(np.diff(self.t_s) < 0):
            raise IdentifyError(f"{self.name}: the time stamps go backwards")
        if not np.any(np.isfinite(self.outputs)):
            raise IdentifyError(f"{self.name}: no measured output")

    @property
    def n(self) -> int:
        return int(self.inputs.size)

    @cached_property
    def rows(self) -> np.ndarray:
        """Indices of the measured points, ``(m,)``."""
        return np.flatnonzero(np.isfinite(self.outputs))

    def keeping(self, rows: np.ndarray) -> "Run":
        """This run with only ``rows`` (indices, ``(m,)``) measured: the other outputs NaN, every applied
        point still there (it still sets the memory)."""
        kept = np.full(self.outputs.shape, np.nan)
        rows = np.asarray(rows, dtype=np.int64)
        kept[rows] = self.outputs[rows]
        return replace(self, outputs=kept)

    @property
    def measured(self) -> np.ndarray:
        """The measured outputs (um), ``(m,)``."""
        return self.outputs[self.rows]

    @cached_property
    def setpoint_t(self) -> np.ndarray:
        """Time (s) each set-point was applied: ``t_s - dwell_s`` (``t_s`` where the dwell is unknown)."""
        d = np.where(np.isfinite(self.dwell_s), self.dwell_s, 0.0)
        return self.t_s - np.clip(d, 0.0, None)

    @cached_property
    def history(self) -> "History":
        return History.of(self)


@dataclass(frozen=True, eq=False)
class History:
    """Per-point quantities derived from a run's input history, each ``(n,)``.

    ``branch``: :data:`HEATING` or :data:`COOLING` -- the direction of the
    last move into the point -- or :data:`AFTER_REVERSAL` for the first
    point after the input turned back.  ``since_reversal_s``: time of the
    readings since the input last turned back (since the start before the
    first reversal).  ``last_step_V``: the move into the point (0 for a
    repeated set-point).  ``reversal_index``/``turn_t``/``excursion_V``
    (``(R,)`` each): every reversal point, the time the input turned back
    from it, and the excursion that ended there (from the previous
    reversal, or from ``initial_V``); ``turn_index`` ``(R,)`` the first
    point after each reversal (the one whose set-point turned back).
    ``reversal_V`` ``(n,)``: the input at the last reversal point at or
    before each point (NaN before the first); on a first-order reversal
    curve, the curve's reversal field.
    """

    branch: np.ndarray
    since_reversal_s: np.ndarray
    last_step_V: np.ndarray
    reversal_index: np.ndarray
    turn_index: np.ndarray
    turn_t: np.ndarray
    excursion_V: np.ndarray
    reversal_V: np.ndarray

    def after_turn(self) -> np.ndarray:
        """``(n, R)`` bool: point ``k`` comes after the input turned back at reversal ``r`` (its
        readings were taken at or after the next set-point; a point read at the very instant the
        input turns is not)."""
        n = self.branch.size
        return np.arange(n)[:, None] >= self.turn_index[None, :]

    @classmethod
    def of(cls, run: Run) -> "History":
        v = run.inputs
        n = v.size
        previous = np.concatenate([[run.initial_V], v[:-1]])
        step = v - previous
        direction = np.sign(step)
        # carry the last real move over repeated set-points (the run starts by rising from saturation)
        moved = np.flatnonzero(direction != 0)
        carry = np.searchsorted(moved, np.arange(n), side="right") - 1
        # a reversal point is turned back from by the next point that moves; the last point of the
        # run (turned back from by the heater going off) is no reversal for what the run recorded
        rev = reversal_points(v)
        rev[-1] = False
        rev_idx = np.flatnonzero(rev)
        nxt = np.searchsorted(moved, rev_idx, side="right")
        ok = nxt < moved.size
        rev_idx, first_after = rev_idx[ok], moved[nxt[ok]]
        turn_t = run.setpoint_t[first_after]
        turning_values = np.concatenate([[run.initial_V], v[rev_idx]])
        excursion = np.diff(turning_values)
        code = branches(v).copy()
        code[first_after] = AFTER_REVERSAL
        # a repeated set-point is where the point before it was: it keeps that point's branch
        # (a run that never leaves its initial input has no move to carry)
        carried = code[moved[np.maximum(carry, 0)]] if moved.size else code
        branch = np.where(carry >= 0, carried, code).astype(np.int8)
        # time since the last turn that happened before each point's readings
        last_turn = np.searchsorted(first_after, np.arange(n), side="right") - 1
        start = run.setpoint_t[0]
        turned = turn_t[np.maximum(last_turn, 0)] if turn_t.size else np.full(n, start)
        since = run.t_s - np.where(last_turn >= 0, turned, start)
        at_or_before = np.searchsorted(rev_idx, np.arange(n), side="right") - 1
        rev_at = v[rev_idx[np.maximum(at_or_before, 0)]] if rev_idx.size else np.zeros(n)
        rev_at = np.where(at_or_before >= 0, rev_at, np.nan)
        return cls(branch, since, step, rev_idx, first_after, turn_t, excursion, rev_at)
