"""Running independent jobs on a pool of processes, in order, with a progress bar on stderr.

Workers are forked from a *fork server*: a clean process started for the
purpose, which imports the modules the jobs need once (``preload``), with
single-threaded BLAS and solver factorisations (on a shared machine,
every worker spreading small matrix products over all cores makes them
slower, not faster).  Forking
this process instead would be faster to start (0.07 s against 2-3 s for
the server's imports on the shared development machine) but is not safe:
once this process has run a Clarabel solve, its Rust thread pool (rayon,
used by the faer factorisations) does not survive a fork, and the forked
worker waits forever for threads that do not exist (seen in the
benchmark).  :func:`start_workers` starts the server early, so its imports
overlap the caller's own work.  Elsewhere than Linux workers are spawned.

Results come back in the order of the jobs, so they do not depend on the
number of workers or on which finishes first.  An error in a job, or
Ctrl-C, terminates the workers at once.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.pool
import os
from typing import Callable, Iterator, Sequence, TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Environment of the worker processes: one BLAS thread each, and one thread for
#: Clarabel's factorisations (faer on a rayon pool, which otherwise takes every core).
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "RAYON_NUM_THREADS": "1"}


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def default_workers(n_jobs: int, requested: int | None = None) -> int:
    """``requested`` processes, else one per available core; never more than the jobs."""
    wanted = available_cores() if requested is None else requested
    return max(1, min(wanted, n_jobs))


@contextlib.contextmanager
def worker_environment() -> Iterator[None]:
    """Set :data:`WORKER_ENV` (unless the user chose otherwise) while workers start."""
    saved = {k: os.environ.get(k) for k in WORKER_ENV}
    for k, v in WORKER_ENV.items():
        os.environ.setdefault(k, v)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def worker_context(preload: Sequence[str] = ()) -> multiprocessing.context.BaseContext:
    """The fork server's context (importing ``preload`` once), or spawning where there is none."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(preload))
        return ctx
    return multiprocessing.get_context("spawn")


def start_workers(preload: Sequence[str] = ()) -> None:
    """Start the fork server now (importing ``preload``) rather than when the pool is made.

    A no-op where there is no fork server, and when it already runs (it
    lives as long as this process; ``preload`` only counts the first time).
    """
    ctx = worker_context(preload)
    if ctx.get_start_method() == "forkserver":
        from multiprocessing import forkserver

        with worker_environment():
            forkserver.ensure_running()


def run_parallel(
    function: Callable[[T], R],
    jobs: Sequence[T],
    workers: int,
    *,
    desc: str = "",
    unit: str = "job",
    preload: Sequence[str] = (),
    progress: bool = True,
) -> list[R]:
    """``[function(job) for job in jobs]``, on ``workers`` processes when more than one.

    ``function`` must be a module-level function of an importable module
    (list it in ``preload`` so that the fork server imports it once), and
    jobs and results picklable.  With one worker (or one job) everything
    runs in this process.  The tqdm bar goes to stderr and only to a
    terminal (``progress=False`` silences it).
    """
    from tqdm import tqdm  # here: a command that never runs a batch need not import it at start-up

    bar = tqdm(total=len(jobs), desc=desc, unit=unit, dynamic_ncols=True, disable=None if progress else True)
    with bar:
        if workers <= 1 or len(jobs) <= 1:
            results = []
            for job in jobs:
                results.append(function(job))
                bar.update()
            return results
        results = []
        with worker_pool(worker_context(preload), workers) as pool:
            for result in pool.imap(function, jobs):
                results.append(result)
                bar.update()
        return results


@contextlib.contextmanager
def worker_pool(context: multiprocessing.context.BaseContext, workers: int,
                initializer: Callable[..., None] | None = None, initargs: tuple = ()
                ) -> Iterator[multiprocessing.pool.Pool]:
    """A pool of ``workers`` processes of ``context``, started in :func:`worker_environment`;
    each worker runs ``initializer(*initargs)`` first, when given.

    An error or an interrupt (Ctrl-C) in the block terminates the workers at
    once; otherwise they are closed; either way they are joined.
    """
    with worker_environment():
        pool = context.Pool(workers, initializer, initargs)
    try:
        yield pool
    except BaseException:
        pool.terminate()
        raise
    else:
        pool.close()
    finally:
        pool.join()
