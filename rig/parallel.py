"""Running independent jobs in parallel, behind one interface: a :class:`concurrent.futures.Executor`.

:func:`open_executor` gives the executor; :func:`run_parallel` maps a
function over jobs on it, with a progress bar on stderr.  Two executors
are interchangeable behind it, chosen by a scheduler address:

* **the local pool** (no address): the standard library's
  :class:`~concurrent.futures.ProcessPoolExecutor`, its processes forked
  from a *fork server* -- a clean process started for the purpose, which
  imports the modules the jobs need once (``preload``) -- with
  single-threaded BLAS and solver factorisations (:data:`WORKER_ENV`: on a
  shared machine, every worker spreading small matrix products over all
  cores makes them slower, not faster).  Forking this process instead
  would be faster to start (0.07 s against 2-3 s for the server's imports
  on the shared development machine) but is not safe: once this process
  has run a Clarabel solve, its Rust thread pool (rayon, used by the faer
  factorisations) does not survive a fork, and the forked worker waits
  forever for threads that do not exist.  :func:`start_workers` starts the
  server early, so its imports overlap the caller's own work.  Elsewhere
  than Linux workers are spawned.
* **this process and one helper** (:func:`map_with_helper`): a map whose jobs
  are taken in turn by this process and by one process of the local pool,
  the function (with the data bound to it) sent to the helper once -- for
  a few large jobs that share a lot of data (the diagnosis's candidates),
  where a pool of its own for every core would pay the imports twice.
* **a dask.distributed cluster** (``scheduler="tcp://host:port"``, the
  ``[cluster]`` extra): the executor of a :class:`distributed.Client`
  connected to that scheduler.  The jobs run on whatever workers the
  cluster has (``docs/how-to/scale-out.md`` says how to start them); a
  worker that is lost is replaced and its jobs run again by dask itself.
  Each job first sets :data:`WORKER_ENV` in its worker process (dask's
  nanny already starts workers with single-threaded BLAS), so a job sees
  the set-up of the local pool.

Jobs are module-level functions of importable modules applied to picklable
arguments, so the same call runs on either.  Results come back in the
order of the jobs, so they depend neither on the number of workers nor on
the executor nor on which job finishes first.  An error in a job, or
Ctrl-C, stops the rest at once: the local pool's processes are
terminated, the cluster's pending jobs cancelled.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import functools
import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Environment of the worker processes: one BLAS thread each, and one thread for
#: Clarabel's factorisations (faer on a rayon pool, which otherwise takes every core).
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "RAYON_NUM_THREADS": "1"}

#: How long to wait for a dask scheduler to answer before saying it cannot be reached (s).
CONNECT_TIMEOUT_S = 10.0


class SchedulerError(Exception):
    """A ``--scheduler`` that cannot be used: dask.distributed is not installed, or nothing answers there."""


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def other_running_tasks(samples: int = 3, interval_s: float = 0.005) -> int | None:
    """How many tasks besides this one the machine is running (or has ready to run) now: the least of a
    few reads of ``/proc/loadavg``'s count, so that a task running only for a moment is not counted; None
    where the system does not say.  A snapshot, not the last minute's average: the average still counts a
    command that has just ended."""
    counts = []
    for i in range(samples):
        try:
            with open("/proc/loadavg", encoding="ascii") as f:
                counts.append(int(f.read().split()[3].split("/")[0]) - 1)
        except (OSError, IndexError, ValueError):
            return None
        if i + 1 < samples:
            time.sleep(interval_s)
    return max(0, min(counts))


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


@contextlib.contextmanager
def open_executor(workers: int, scheduler: str | None = None, *,
                  preload: Sequence[str] = ()) -> Iterator[concurrent.futures.Executor]:
    """A :class:`concurrent.futures.Executor`: the cluster at ``scheduler``, else a pool of ``workers``
    local processes (forked from the fork server, which imports ``preload``).

    An error or an interrupt (Ctrl-C) in the block stops the jobs at once;
    otherwise the block's jobs are waited for.  :class:`SchedulerError` if
    the scheduler cannot be used.
    """
    if scheduler is not None:
        with _cluster_executor(scheduler) as executor:
            yield executor
        return
    with worker_environment():
        pool = concurrent.futures.ProcessPoolExecutor(workers, mp_context=worker_context(preload))
    try:
        yield pool
    except BaseException:
        _terminate(pool)
        raise
    else:
        pool.shutdown(wait=True)


def _terminate(pool: concurrent.futures.ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the running processes now (the standard library's pool only
    waits for them: ``terminate_workers`` is Python 3.14's)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(5)


@contextlib.contextmanager
def _connect(scheduler: str) -> Iterator["distributed.Client"]:  # noqa: F821
    """A dask.distributed client of the scheduler at ``scheduler``, closed after the block."""
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerError(f"--scheduler {scheduler}: needs dask.distributed; "
                             "install it with pip install 'vo2rig[cluster]'") from None
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        parse_host_port(parse_address(scheduler)[1])
    except ValueError as exc:
        raise SchedulerError(f"--scheduler {scheduler}: not a scheduler address ({exc}); "
                             "give tcp://HOST:PORT") from None
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerError(f"--scheduler {scheduler}: cannot reach a dask scheduler there "
                             f"({exc or type(exc).__name__})") from None
    try:
        yield client
    finally:
        client.close()


@contextlib.contextmanager
def _cluster_executor(scheduler: str) -> Iterator[concurrent.futures.Executor]:
    with _connect(scheduler) as client:
        executor = client.get_executor(pure=False)  # every job runs, even two with equal arguments
        try:
            yield executor
        except BaseException:
            executor.shutdown(wait=False)  # cancels the jobs not finished
            raise


def cluster_workers(scheduler: str) -> int:
    """How many jobs the cluster at ``scheduler`` runs at once (its workers' threads, summed)."""
    with _connect(scheduler) as client:
        return max(1, sum(client.nthreads().values()))


def _in_worker(function: Callable[[T], R], job: T) -> R:
    """``function(job)`` in a cluster's worker process, with the local pool's :data:`WORKER_ENV`
    (effective for what starts after it: Clarabel's thread pool, on its first solve)."""
    for k, v in WORKER_ENV.items():
        os.environ.setdefault(k, v)
    return function(job)


def run_parallel(
    function: Callable[[T], R],
    jobs: Sequence[T],
    workers: int,
    *,
    desc: str = "",
    unit: str = "job",
    preload: Sequence[str] = (),
    progress: bool = True,
    scheduler: str | None = None,
    size: Callable[[T], int] = lambda job: 1,
) -> list[R]:
    """``[function(job) for job in jobs]``, on ``workers`` local processes when more than one, or on the
    dask cluster at ``scheduler`` when given.

    ``function`` must be a module-level function of an importable module
    (list it in ``preload`` so that the fork server imports it once; a
    cluster's workers import it themselves, so it must be installed there
    too), and jobs and results picklable.  Without a scheduler, with one
    worker (or one job) everything runs in this process.  The tqdm bar goes
    to stderr and only to a terminal (``progress=False`` silences it); it
    counts ``size(job)`` units a job (one by default).
    """
    from tqdm import tqdm  # here: a command that never runs a batch need not import it at start-up

    bar = tqdm(total=sum(size(job) for job in jobs), desc=desc, unit=unit, dynamic_ncols=True,
               disable=None if progress else True)
    with bar:
        if scheduler is None and (workers <= 1 or len(jobs) <= 1):
            results = []
            for job in jobs:
                results.append(function(job))
                bar.update(size(job))
            return results
        with open_executor(workers, scheduler, preload=preload) as executor:
            if scheduler is None:
                futures = [executor.submit(function, job) for job in jobs]
            else:
                futures = [executor.submit(_in_worker, function, job) for job in jobs]
            job_of = {f: job for f, job in zip(futures, jobs)}
            for done in concurrent.futures.as_completed(futures):
                done.result()  # the first error stops the rest
                bar.update(size(job_of[done]))
            return [f.result() for f in futures]


#: The function a helper process of :func:`map_with_helper` runs (set as it starts).
_installed: Callable | None = None


def _install(function: Callable) -> None:
    global _installed
    _installed = function


def _started() -> bool:
    return _installed is not None


def _run_installed(item):
    return _installed(item)


def map_with_helper(function: Callable[[T], R], items: Sequence[T], preload: Sequence[str] = ()) -> list[R]:
    """``[function(item) for item in items]``, the items taken in their order by this process and by one
    helper process of the local pool (forked from the fork server, which imports ``preload``), each as it
    becomes free.

    ``function`` (e.g. a :func:`functools.partial` of a module-level function with the jobs' shared data
    bound) is pickled once, when the helper starts; each item and result then travel alone.  The helper
    takes its first item once it has started (until then this process takes them all), and a helper
    that cannot start leaves them all to this process.  The results come in the order of the items and
    do not depend on who computed them, provided both processes compute alike (the helper has
    :data:`WORKER_ENV`: one BLAS thread, as the caller should have too).  An error is raised as the serial
    loop would raise it: the first failing item's, once the items before it are done; Ctrl-C ends the
    helper at once.
    """
    items = list(items)
    if len(items) < 2:
        return [function(item) for item in items]
    outcomes: list[tuple[bool, object] | None] = [None] * len(items)
    lock = threading.Lock()
    state = {"next": 0, "stop": False}

    def claim() -> int | None:
        with lock:
            if state["stop"] or state["next"] >= len(items):
                return None
            state["next"] += 1
            return state["next"] - 1

    def record(i: int, ok: bool, value: object) -> None:
        with lock:
            outcomes[i] = (ok, value)
            state["stop"] = state["stop"] or not ok

    with worker_environment():
        pool = concurrent.futures.ProcessPoolExecutor(1, mp_context=worker_context(preload), initializer=_install,
                                                      initargs=(function,))

    def helper() -> None:
        try:
            pool.submit(_started).result()
        except BaseException:  # noqa: BLE001 -- it could not start: this process takes every item
            return
        while (i := claim()) is not None:
            try:
                record(i, True, pool.submit(_run_installed, items[i]).result())
            except BaseException as exc:  # noqa: BLE001 -- the job's error (or a broken pool), raised below in order
                record(i, False, exc)

    thread = threading.Thread(target=helper, name="map_with_helper", daemon=True)
    try:
        thread.start()
        while (i := claim()) is not None:
            try:
                record(i, True, function(items[i]))
            except Exception as exc:  # noqa: BLE001 -- raised below, after any earlier item's error
                record(i, False, exc)
        thread.join()
    except BaseException:  # Ctrl-C: the helper's job is not waited for
        with lock:
            state["stop"] = True
        _terminate(pool)
        raise
    pool.shutdown(wait=True)
    results = []
    for outcome in outcomes:
        assert outcome is not None  # only items after a failed one are left out, and that one is raised first
        ok, value = outcome
        if not ok:
            raise value
        results.append(value)
    return results


def helper_mapper(preload: Sequence[str] = ()) -> Callable[[Callable[[T], R], Sequence[T]], list[R]] | None:
    """:func:`map_with_helper` (importing ``preload``) when a second core is free now -- two or more cores,
    and fewer other tasks running than the cores beside this one (a busy core would only split this
    command's share between the two processes) -- with the fork server started at once, so that its imports
    overlap the caller's own work; else None (the caller maps one item after the other).  The caller
    decides first whether the jobs are work enough to pay for the helper's start, and whether both
    processes compute alike (the helper has one BLAS thread)."""
    cores = available_cores()
    if cores < 2 or (other_running_tasks() or 0) >= cores - 1:
        return None
    start_workers(preload)
    return functools.partial(map_with_helper, preload=tuple(preload))
