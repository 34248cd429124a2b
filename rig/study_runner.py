"""Run the study's trials in parallel (:mod:`rig.parallel`: local processes or a dask cluster), with a
progress bar on stderr.

Each trial is seeded from ``(seed, M, run)`` alone (see
:mod:`identify.study.trial`), and the trials come back in their order, so
the results depend neither on the number of workers nor on where they run.
Workers run single-threaded BLAS: on a shared machine, every worker
spreading its small matrix products over all cores makes them tens of times
slower, not faster.
"""

from __future__ import annotations

import functools
import math

# The methods import scipy.optimize and scipy.fft on first use (so that the rig command does not pay for
# them at start-up); the study's workers import this module, so no trial's fit time includes an import.
import scipy.fft  # noqa: F401
import scipy.optimize  # noqa: F401

from identify.study import StudyDesign, StudySetup, TrialResult, run_trials

from .parallel import cluster_workers, run_parallel


def _chunks(keys: list, workers: int) -> list[list]:
    size = max(1, min(8, math.ceil(len(keys) / (workers * 16))))
    return [keys[i : i + size] for i in range(0, len(keys), size)]


@functools.lru_cache(maxsize=2)
def _design(levels: int) -> StudyDesign:
    """The study design at ``levels``, built once per process: all the trials a worker process runs fit on
    it, sharing the operator and square solver."""
    return StudyDesign.of(levels)


def _run_chunk(args: tuple[StudySetup, list]) -> list[TrialResult]:
    setup, keys = args
    return run_trials(setup, keys, _design(setup.levels))


def run_study(setup: StudySetup, workers: int, progress: bool = True,
              scheduler: str | None = None) -> list[TrialResult]:
    """Every trial of ``setup``, in order, on ``workers`` local processes or on the dask cluster at
    ``scheduler``; a tqdm bar on stderr if ``progress``.

    An interrupt (Ctrl-C) or an error stops the workers at once.
    """
    keys = setup.trials()
    if scheduler is not None:
        workers = cluster_workers(scheduler)
    chunks = _chunks(keys, workers)
    results = run_parallel(_run_chunk, [(setup, c) for c in chunks], workers, desc=f"study {setup.profile}",
                           unit="run", preload=[__name__], progress=progress, scheduler=scheduler,
                           size=lambda job: len(job[1]))
    return [trial for chunk in results for trial in chunk]
