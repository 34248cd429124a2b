"""Run the study's trials on a pool of processes, with a progress bar on stderr.

Each trial is seeded from ``(seed, M, run)`` alone (see
:mod:`identify.study.trial`), so the results do not depend on the number of
workers or on the order in which they finish.  Workers are started with
``spawn`` and single-threaded BLAS: on a shared machine, every worker
spreading its small matrix products over all cores makes them tens of times
slower, not faster.
"""

from __future__ import annotations

import math
import multiprocessing

# The methods import scipy.optimize and scipy.fft on first use (so that the rig command does not pay for
# them at start-up); the study's workers import this module, so no trial's fit time includes an import.
import scipy.fft  # noqa: F401
import scipy.optimize  # noqa: F401
from tqdm import tqdm

from identify.study import StudyDesign, StudySetup, TrialResult, run_trials

from .parallel import worker_pool

def _chunks(keys: list, workers: int) -> list[list]:
    size = max(1, min(8, math.ceil(len(keys) / (workers * 16))))
    return [keys[i : i + size] for i in range(0, len(keys), size)]


#: The study design of this worker process (set by :func:`_start_worker`): all its trials fit on it,
#: sharing the operator and square solver, as the trials of one process do.
_worker_design: StudyDesign | None = None


def _start_worker(levels: int) -> None:
    global _worker_design
    _worker_design = StudyDesign.of(levels)


def _run_chunk(args: tuple[StudySetup, list]) -> list[TrialResult]:
    setup, keys = args
    return run_trials(setup, keys, _worker_design)


def run_study(setup: StudySetup, workers: int, progress: bool = True) -> list[TrialResult]:
    """Every trial of ``setup`` on ``workers`` processes; a tqdm bar on stderr if ``progress``.

    An interrupt (Ctrl-C) or an error terminates the workers at once.
    """
    keys = setup.trials()
    results: list[TrialResult] = []
    context = multiprocessing.get_context("spawn")
    with tqdm(total=len(keys), desc=f"study {setup.profile}", unit="run", dynamic_ncols=True,
              disable=None if progress else True) as bar:
        with worker_pool(context, workers, _start_worker, (setup.levels,)) as pool:
            for batch in pool.imap_unordered(_run_chunk, [(setup, c) for c in _chunks(keys, workers)]):
                results.extend(batch)
                bar.update(len(batch))
    return results
