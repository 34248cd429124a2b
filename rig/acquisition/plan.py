"""The acquisition plan: the excitation to apply, where to measure, where to settle.

An :class:`AcquisitionPlan` wraps the session's :class:`~sessions.ExcitationRecord`
(the planned inputs and the ``measure`` mask, stored in ``/excitation``)
with what the sequencer derives from it: the reversal points, which must
settle (see :mod:`identify.acquisition_plan`), and the flags of every point.
A resumed session rebuilds the same plan from its record.

:func:`make_record` builds the record of a new run: the excitation, the
compressive measurement plan (``M`` measured points in all, the reversal
points always among them) and the dwell settings.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from drivers.errors import LimitError
from drivers.protocols import VoltageWindow
from identify.acquisition_plan import compressive_plan, reversal_points
from sessions import ExcitationRecord, SampleFlag

from .dwell import DwellSettings
from .errors import AcquisitionError


@dataclass(frozen=True, eq=False)
class AcquisitionPlan:
    """What to apply and where to measure; arrays have shape ``(N,)``.

    ``inputs`` (V); ``measure``, ``reversals`` bool; ``flags`` the
    :class:`~sessions.SampleFlag` bits every point gets from the plan
    (reversal, thermal-term point).  ``settle`` = ``measure | reversals``:
    the points that get the full dwell.
    """

    record: ExcitationRecord
    reversals: np.ndarray
    flags: np.ndarray

    @classmethod
    def from_record(cls, record: ExcitationRecord) -> "AcquisitionPlan":
        rev = reversal_points(record.inputs)
        flags = np.where(rev, int(SampleFlag.REVERSAL), 0).astype(np.uint32)
        if record.thermal_term and record.n_points:
            flags[-1] |= int(SampleFlag.THERMAL_POINT)
        return cls(record, rev, flags)

    @property
    def inputs(self) -> np.ndarray:
        return self.record.inputs

    @property
    def measure(self) -> np.ndarray:
        return self.record.measure

    @property
    def settle(self) -> np.ndarray:
        return self.record.measure | self.reversals

    @property
    def n_points(self) -> int:
        return self.record.n_points

    def check_settings(self, settings: DwellSettings) -> None:
        """Refuse per-point dwell times that do not match the plan point for point."""
        if settings.schedule is not None and len(settings.schedule) != self.n_points:
            raise AcquisitionError(
                f"{len(settings.schedule)} per-point dwell times for a plan of {self.n_points} points"
            )

    def check_window(self, window: VoltageWindow, check: Callable[[float], float] | None = None) -> None:
        """Refuse (before anything is applied) a plan with a set-point outside the heater's window -- and,
        given ``check`` (a heater's ``check_setpoint``: every rule as the wire will carry the value, the
        instrument's full scale too), with a set-point it refuses.  The message names the first such point
        and says why."""
        bad = np.flatnonzero((self.inputs < window.min_V) | (self.inputs > window.max_V))
        if bad.size:
            k = int(bad[0])
            v = float(self.inputs[k])
            why = "; nothing was applied"
            if check is not None:
                try:
                    check(v)
                except LimitError as exc:
                    why = f": {exc}"
            raise AcquisitionError(
                f"point {k} of the plan ({v:.9g} V) is outside the heater's window "
                f"[{window.min_V:.9g}, {window.max_V:.9g}] V ({bad.size} point(s) in all){why}"
            )
        if check is None:
            return
        refused: dict[float, LimitError] = {}
        for u in np.unique(self.inputs):
            try:
                check(float(u))
            except LimitError as exc:
                refused[float(u)] = exc
        if refused:
            hit = np.isin(self.inputs, list(refused))
            k = int(np.argmax(hit))
            v = float(self.inputs[k])
            raise AcquisitionError(
                f"point {k} of the plan ({v:.9g} V) cannot be applied ({int(hit.sum())} point(s) in all): {refused[v]}"
            )


def make_record(
    excitation: ExcitationRecord, settings: DwellSettings, measure: int | None = None, seed: int | None = 0
) -> ExcitationRecord:
    """The record of a new run: ``excitation`` with its measurement plan and dwell settings.

    ``measure`` = M measures M points in all, the reversal points always
    among them, the rest chosen at random with ``seed``; ``None`` measures
    every point.
    """
    n = excitation.n_points
    if n == 0:
        raise AcquisitionError("the excitation has no points")
    if settings.schedule is not None and len(settings.schedule) != n:
        raise AcquisitionError(f"{len(settings.schedule)} per-point dwell times for a plan of {n} points")
    rev = reversal_points(excitation.inputs)
    mask = compressive_plan(n, measure, seed, rev)
    extra = dict(excitation.extra)
    extra.update(n_reversals=int(rev.sum()), n_measured=int(mask.sum()))
    if measure is not None:
        extra.update(measure=int(measure), measure_seed=seed)
    return dataclasses.replace(excitation, measure=mask, dwell=settings.describe(), extra=extra)
