"""``rig acquire --target-nrmse X``: acquire until the model's predicted held-out error reaches X.

The rig's side of :class:`identify.sequential.SequentialDesign` (pure): a
:class:`~rig.acquisition.setpoint_source.SetpointSource` that asks the design for
each next set-point, tells it what was read, records the predicted check
nRMSE with every point, reports it as it falls, and ends the run -- complete,
with fewer points than its most -- when the prediction reaches the target,
when the next point would pass the ``--rig-time`` cap, or at the most
points.  The session's excitation is of kind ``adaptive`` (its planned
inputs are placeholders; the applied inputs are the samples) and records
the recipe the prediction is about (``smooth_nn`` on the grid: a smooth,
non-negative density, as the design's prior assumes).

The design's prior and noise come from the bench (:mod:`.timed`: the
reference device and the noise of one reading): the prior sd of a cell is
the reference's rms cell weight, and of a difference of neighbours the
same.  The prediction assumes points at rest (quasi-static), so the run
finds its own dwell (:mod:`identify.settling`): it starts at ``--dwell``
(:data:`FIRST_DWELL_S` when not given) and doubles it, up to
:data:`MAX_DWELL_S`, whenever settle replicates -- the previous set-point
held four times as long -- show the points were not at rest; the points
the longer dwell supersedes stay in the session (they set the memory) but
no fit uses them.  With ``--settle`` the settle condition decides each
wait instead, and the dwell is not changed.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from identify import Grid
from identify.sequential import KIND_CODES, SequentialDesign
from sessions import ADAPTIVE_KIND, ExcitationRecord

from .errors import AcquisitionError
from .timed import reading_costs, reference_device

#: The recipe a run to a target records (what its prediction is about).
ADAPTIVE_METHOD = "smooth_nn"
#: Most points without ``--points``: this many times the model's unknowns.
MOST_POINTS_PER_UNKNOWN = 2
#: The first dwell of a run to a target without ``--dwell`` (s): short, since the run lengthens it itself.
FIRST_DWELL_S = 1.0
#: The longest dwell a run to a target lengthens its own to (s).
MAX_DWELL_S = 600.0
#: How often (points) the predicted error is reported.
REPORT_EVERY = 10


def design_for(cfg, grid: Grid, window: tuple[float, float], readings: int, seed: int,
               thermal_term: bool = True, dwell_s: float | None = None) -> SequentialDesign:
    """The sequential design of a run on ``cfg``'s rig (see the module docstring); ``dwell_s`` (s): its
    first dwell, lengthened as its settle replicates demand (None: a wait the design does not set)."""
    noise_um, _ = reading_costs(cfg)
    ref = reference_device(cfg, grid)
    cell = float(np.sqrt(np.mean(np.square(ref.density))))
    return SequentialDesign(grid, noise_um=noise_um / math.sqrt(readings), scale_um=cell, smooth_um=cell,
                            window=window, thermal_term=thermal_term, seed=seed, dwell_s=dwell_s,
                            max_dwell_s=MAX_DWELL_S)


def check_target(target: float, design: SequentialDesign, span_um: float) -> None:
    """Refuse a target that is not a positive number, or below the noise floor of a device of output span
    ``span_um`` (um)."""
    if not (math.isfinite(target) and target > 0):
        raise AcquisitionError(f"--target-nrmse must be a positive number, got {target:g}")
    floor = design.floor_nrmse(span_um)
    if target < floor:
        raise AcquisitionError(f"--target-nrmse {target:g} is below the noise floor: one point's noise alone is "
                               f"{floor:.2g} of the output span; more readings per point (--readings) lower it")


def adaptive_record(grid: Grid, most: int, thermal_term: bool, seed: int, target: float,
                    cap_s: float | None, first_dwell_s: float | None = None) -> ExcitationRecord:
    """The excitation of a run to a target: ``most`` placeholder points (the lowest wall) of kind
    ``adaptive``, every one measured, with the target and the cap kept in ``extra`` -- and, when the run
    finds its own dwell, ``first_dwell_s`` and ``max_dwell_s`` (s), which tell a reader of the session to
    leave out the points a longer dwell superseded (:func:`identify.settling.superseded`)."""
    extra = {"target_nrmse": target, "rig_time_cap_s": cap_s}
    if first_dwell_s is not None:
        extra.update(first_dwell_s=float(first_dwell_s), max_dwell_s=MAX_DWELL_S)
    return ExcitationRecord(kind=ADAPTIVE_KIND, inputs=np.full(most, grid.v_min), levels=grid.levels,
                            v_min=grid.v_min, v_max=grid.v_max, thermal_term=thermal_term, seed=seed, extra=extra)


class AdaptiveSetpoints:
    """The set-point source of a run to ``target`` (check nRMSE) within ``cap_s`` seconds (None: none);
    ``dwell_s`` (s) is each point's planned wait when the design does not set it (a settle condition),
    ``report(k, predicted, t_s)`` is told the prediction every :data:`REPORT_EVERY` points and
    ``lengthened(k, old_s, new_s)`` each time the run lengthens its dwell."""

    def __init__(self, design: SequentialDesign, target: float, cap_s: float | None, dwell_s: float,
                 report: Callable[[int, float, float], None] | None = None,
                 lengthened: Callable[[int, float, float], None] | None = None) -> None:
        self.design, self.target, self.cap_s, self.dwell_s = design, float(target), cap_s, float(dwell_s)
        self.report, self.lengthened = report, lengthened
        self.predicted = math.inf
        self.reason = "most points"
        self._kind = "design"
        self._wait: float | None = None

    def finished(self, k: int, t_s: float) -> bool:
        if self.design.reached(self.target):
            self.reason = "target reached"
            return True
        wait = self.dwell_s if self.design.dwell_s is None else self.design.dwell_s
        if self.cap_s is not None and t_s + wait > self.cap_s:
            self.reason = "rig-time cap"
            return True
        return False

    def setpoint(self, k: int, t_s: float, dwell_s: float) -> float:
        v = self.design.next_input()
        self._kind = self.design.proposed
        self._wait = self.design.next_dwell()
        return v

    def dwell_for(self, k: int) -> float | None:
        return self._wait

    def measured(self, k: int, v: float, t_s: float, dwell_s: float, deflection_um: float) -> dict[str, float]:
        kind, before, asked = self._kind, self.design.dwell_s, self._wait
        # judged by the wait asked, not the one recorded (a pause lengthens that): as a reader of the session is
        self.design.add(v, deflection_um, kind, waited_s=dwell_s if asked is None else asked)
        self.predicted = self.design.predicted_nrmse()
        if self.report is not None and (k + 1) % REPORT_EVERY == 0:
            self.report(k + 1, self.predicted, t_s)
        if before is not None and self.design.dwell_s != before and self.lengthened is not None:
            self.lengthened(k + 1, before, self.design.dwell_s)
        return {"predicted_nrmse": self.predicted, "point_kind": KIND_CODES[kind],
                "asked_dwell_s": math.nan if asked is None else asked}
