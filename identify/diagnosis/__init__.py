"""Sim-to-real gap diagnosis: where equation (22) misses, which unmodelled effect causes it, how far
the gap shrinks once that effect is added.

Pure numerics, one module per job:

* :mod:`identify.runs` -- a recorded run and what its input history implies (shared with the effects);
* :mod:`~identify.diagnosis.check_run_design` -- the check-run input design;
* :mod:`~identify.diagnosis.base` -- the base model on the identification runs, linearised;
* :mod:`~identify.diagnosis.candidates` -- the candidate augmentations (one per effect);
* :mod:`~identify.diagnosis.resolution` -- the same model on a finer grid, as a candidate;
* :mod:`~identify.diagnosis.noise` -- the noise floor;
* :mod:`~identify.diagnosis.binning` -- the residual bins ("where");
* :mod:`~identify.diagnosis.verdict` -- the decision rule;
* :mod:`~identify.diagnosis.engine` -- :func:`diagnose`, tying them together.
"""

from .candidates import CANDIDATES, NAMES, Candidate, library
from .check_run_design import CheckDesign, check_design
from .engine import CandidateScore, Diagnosis, DiagnosisSettings, diagnose
from ..runs import Run
from .verdict import STATUSES, Verdict

__all__ = [
    "CANDIDATES",
    "NAMES",
    "STATUSES",
    "Candidate",
    "CandidateScore",
    "CheckDesign",
    "Diagnosis",
    "DiagnosisSettings",
    "Run",
    "Verdict",
    "check_design",
    "diagnose",
    "library",
]
