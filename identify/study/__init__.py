"""The paper's simulation study (section 4), run by run, as pure numerics.

* :mod:`~identify.study.setup` -- what is simulated (:class:`StudySetup`);
* :mod:`~identify.study.trial` -- one run: fresh noise, rows and densities;
* :mod:`~identify.study.sparsity` -- the DCT sparsity count of figure 3;
* :mod:`~identify.study.summary` -- means over runs, paired comparisons;
* :mod:`~identify.study.paper` -- the paper's published figures and claims,
  checked against ours.

Running the trials in parallel, printing and plotting belong to
``rig study``.
"""

from .paper import PAPER, Finding, findings
from .setup import StudySetup, default_noise_sweep, default_measurement_sweep
from .summary import MethodSummary, PointSummary, StudySummary, summarise
from .trial import METRICS, StudyDesign, TrialResult, dct_example, run_trial, run_trials

__all__ = [
    "METRICS",
    "PAPER",
    "Finding",
    "MethodSummary",
    "PointSummary",
    "StudyDesign",
    "StudySetup",
    "StudySummary",
    "TrialResult",
    "dct_example",
    "default_measurement_sweep",
    "default_noise_sweep",
    "findings",
    "run_trial",
    "run_trials",
    "summarise",
]
