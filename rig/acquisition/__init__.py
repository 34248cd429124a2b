"""Acquisition: apply an excitation through the rig, dwell, measure, and record every point in a session.

One module, one job:

* :mod:`~rig.acquisition.sequence` -- the excitation: damped oscillation,
  random validation input, or a CSV file of set-points;
* :mod:`~rig.acquisition.plan` -- the plan: where to measure (compressive
  acquisition), where to settle (reversal points);
* :mod:`~rig.acquisition.dwell` -- dwell policies and settle conditions;
* :mod:`~rig.acquisition.interrupt` -- Ctrl-C: once pauses, twice aborts;
* :mod:`~rig.acquisition.engine` -- the sequencer (heater, sensor and clock
  protocols only);
* :mod:`~rig.acquisition.runner` -- a run from start to end, and resuming
  an interrupted session (saturate, replay, continue);
* :mod:`~rig.acquisition.summary` -- what a run did and the time it saved;
* :mod:`~rig.acquisition.progress` -- the progress bar and the pause prompt.
"""

from .dwell import DwellOutcome, DwellSettings, FixedDwell, RateBelow, SettleDwell, Transit
from .engine import PointResult, Sequencer
from .errors import AcquisitionError
from .interrupt import Aborted, PauseInfo, PauseSwitch
from .plan import AcquisitionPlan, make_record
from .runner import Hooks, RunOutcome, acquire, resume
from .sequence import sequence_dwells, sequence_record
from .summary import summarise, time_budget

__all__ = [
    "Aborted",
    "AcquisitionError",
    "AcquisitionPlan",
    "DwellOutcome",
    "DwellSettings",
    "FixedDwell",
    "Hooks",
    "PauseInfo",
    "PauseSwitch",
    "PointResult",
    "RateBelow",
    "RunOutcome",
    "Sequencer",
    "SettleDwell",
    "Transit",
    "acquire",
    "make_record",
    "resume",
    "sequence_dwells",
    "sequence_record",
    "summarise",
    "time_budget",
]
