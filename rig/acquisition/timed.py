"""``rig acquire --rig-time S``: the bench's side of a plan within a rig-time budget.

The plan itself is :func:`identify.rig_time.plan_within` (pure).  This
module gives it what only the bench knows -- the device it takes its
expectation on, the noise of one reading and the time a reading takes --
and refuses the options that would contradict it.

* Reference device: equation (22) of the ``[sim]`` table's device on the
  plan's grid (its transition density, bias and thermal term).  On the
  simulated device that is the device itself (its time constant is *not*
  used: the plan must work for a time constant nobody told it); on a real
  rig it is the ``[sim]`` defaults, a typical VO2 beam.
* Noise of one reading: the simulated PSD's (``psd_noise_V`` times
  ``psd_um_per_V``); on a real rig :data:`REAL_NOISE_UM`.
* Time of one reading: 0 on the virtual clock (the simulated device reads
  instantly); on a real clock :data:`REAL_READING_S`.
"""

from __future__ import annotations

import numpy as np

from drivers.sim.transition import transition_density
from identify import Grid, PreisachModel
from identify.errors import IdentifyError
from identify.rig_time import DWELL_SPREAD, TimedPlan, plan_within

from .errors import AcquisitionError

#: rms of one PSD reading on a real rig (um), as the bench's calibration runs show it (about).
REAL_NOISE_UM = 0.01
#: Time one reading takes on a real rig (s): a Modbus round trip plus the PSD's averaging, about.
REAL_READING_S = 0.005
#: Options a rig-time plan chooses itself (given with --rig-time: exit 2).
CONTRADICTING = ("dwell", "dwells", "settle", "measure", "identify_with", "transit", "points")


def reference_device(cfg, grid: Grid) -> PreisachModel:
    """Equation (22) of ``cfg``'s ``[sim]`` device on ``grid`` (see the module docstring)."""
    p = cfg.sim
    return PreisachModel(grid, np.asarray(transition_density(grid, p)), mu0=p.bias_um,
                         c_d=p.thermal_um_per_V)


def reading_costs(cfg) -> tuple[float, float]:
    """``(noise_um, reading_s)``: the rms of one reading (um) and its duration (s) on ``cfg``'s rig."""
    if cfg.clock_kind == "virtual":
        return float(cfg.sim.psd_noise_V * cfg.sim.psd_um_per_V), 0.0
    return REAL_NOISE_UM, REAL_READING_S


def check_options(sequence: str, given: list[str]) -> None:
    """Refuse what contradicts a rig-time plan: another sequence than ``damped``, or an option it chooses."""
    if sequence != "damped":
        raise AcquisitionError(f"--rig-time plans the damped oscillation, not --sequence {sequence}")
    if given:
        raise AcquisitionError(f"--rig-time chooses the dwells, the measured points and the recipe itself; "
                               f"{', '.join(given)} contradicts it")


def timed_plan(cfg, grid: Grid, budget_s: float, *, thermal_term: bool, readings: int | None,
               seed: int) -> TimedPlan:
    """The plan within ``budget_s`` on ``cfg``'s rig; :class:`AcquisitionError` (exit 2) for a budget no
    plan fits, naming the least one."""
    noise_um, reading_s = reading_costs(cfg)
    try:
        return plan_within(grid, budget_s, reference_device(cfg, grid), thermal_term=thermal_term,
                           readings=readings, reading_s=reading_s, noise_um=noise_um, seed=seed)
    except IdentifyError as e:
        raise AcquisitionError(str(e)) from None


def describe(plan: TimedPlan) -> str:
    """One line: what the plan does with its budget."""
    c = plan.chosen
    if c.kind == "model":
        how = (f"thermal lag modelled (rig identify --with {','.join(plan.effects)}): reversal points "
               f"{c.reversal_dwell_s:.3g} s, the others {c.scale_s * min(DWELL_SPREAD):.3g}-"
               f"{c.scale_s * max(DWELL_SPREAD):.3g} s")
    else:
        how = f"transient waited out: {c.scale_s:.3g} s at every point, no lag in the model"
    worst = max(c.expected_nrmse.values())
    each = f"{plan.readings} reading{'s' if plan.readings != 1 else ''} each"
    return (f"rig-time plan: {plan.n_points} points, {each}, {how}; "
            f"{plan.rig_time_s:.0f} s of {plan.budget_s:.0f} s; expected check nRMSE "
            f"{min(c.expected_nrmse.values()):.2g}-{worst:.2g} over time constants "
            f"{', '.join(f'{t:g}' for t in c.expected_nrmse)} s")
