"""One worker process that runs one kind of job at a time, and never makes its caller wait.

The watch's model so far, its diagnosis and its drawing each run on one
:class:`Worker` (forked from the fork server, :mod:`rig.parallel`): the
caller submits a job only when the worker is free, so a slow job is never
queued behind ("latest wins": the next job is built from the newest data),
and it collects the result when it is ready.  A job that raises returns the
error as an exception object; a process that dies or hangs past
``timeout_s`` is replaced for the next job.
"""

from __future__ import annotations

import time
from typing import Any, Callable


def _serve(conn, function: Callable[[Any], Any], nice: int) -> None:
    """The worker process: answer every job received on ``conn`` with ``function(job)`` (or the
    exception it raised), at a lower CPU priority, until the pipe closes."""
    import os
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group; the watch ends us
    os.nice(nice)
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        try:
            result = function(job)
        except Exception as exc:  # report it on the page, keep serving
            result = RuntimeError(f"{type(exc).__name__}: {exc}")
        try:
            conn.send(result)
        except (BrokenPipeError, OSError):  # the watch stopped meanwhile
            return


class Worker:
    """Runs ``function(job)`` on one worker process, one job at a time, without ever waiting.

    :meth:`submit` starts a job when the worker is free (else returns False:
    the caller keeps its newest data for later); :meth:`result` returns a
    finished job's result once (``None`` while none is ready; an exception
    object when the job or the process failed).  The process is forked from
    the fork server (:mod:`rig.parallel`) on first use and runs at a lower CPU
    priority (``nice``) than the caller, so a fit never competes with an
    acquisition on a busy machine.  A process that died is started again
    for the next job; one that takes longer than ``timeout_s`` is stopped.
    """

    def __init__(self, function: Callable[[Any], Any], *, preload: tuple[str, ...] = (), nice: int = 5,
                 timeout_s: float = 300.0) -> None:
        self.function = function
        self.timeout_s = timeout_s
        self._preload = ("rig.watch.worker", *preload)
        self._nice = nice
        self._proc = None
        self._conn = None
        self._pending = False
        self._started = 0.0
        #: Who submitted the job under way (see :meth:`submit`).
        self.owner: Any = None

    @property
    def busy(self) -> bool:
        return self._pending

    def _start(self) -> None:
        from ..parallel import worker_context, worker_environment

        ctx = worker_context(self._preload)
        self._conn, child = ctx.Pipe()
        with worker_environment():
            self._proc = ctx.Process(target=_serve, args=(child, self.function, self._nice), daemon=True,
                                     name=f"rig-watch-{self.function.__name__}")
            self._proc.start()
        child.close()

    def submit(self, job: Any, owner: Any = None) -> bool:
        """Start ``job`` if the worker is free; False (nothing done) if it is busy.  ``owner`` (whoever
        should take the result, when several share the worker) is kept as :attr:`owner` until then."""
        if self._pending:
            return False
        if self._proc is None or not self._proc.is_alive():
            self.close()
            self._start()
        self._conn.send(job)
        self._pending, self._started, self.owner = True, time.monotonic(), owner
        return True

    def result(self) -> Any | None:
        """The finished job's result, once (then :attr:`owner` is None again); ``None`` while it runs."""
        out = self._take()
        if out is not None:
            self.owner = None
        return out

    def _take(self) -> Any | None:
        if not self._pending:
            return None
        try:
            ready = self._conn.poll()
        except (EOFError, OSError):
            ready = True
        if ready:
            self._pending = False
            try:
                return self._conn.recv()
            except (EOFError, OSError):
                code = self._proc.exitcode if self._proc is not None else None
                self.close()
                return RuntimeError(f"the worker process ended unexpectedly (exit code {code}); restarting it")
        if self._proc is None or not self._proc.is_alive():
            code = self._proc.exitcode if self._proc is not None else None
            self.close()
            return RuntimeError(f"the worker process ended unexpectedly (exit code {code}); restarting it")
        if time.monotonic() - self._started > self.timeout_s:
            self.close()
            return RuntimeError(f"the worker took longer than {self.timeout_s:g} s and was restarted")
        return None

    def close(self) -> None:
        """Stop the worker process at once (a job in progress is abandoned)."""
        proc, conn = self._proc, self._conn
        self._proc = self._conn = None
        self._pending = False
        if proc is not None:
            proc.terminate()
            proc.join(5)
            if proc.is_alive():
                proc.kill()
                proc.join(5)
        if conn is not None:
            conn.close()
