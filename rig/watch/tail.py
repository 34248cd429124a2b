"""Following one session file as another process writes it, read-only, through whatever happens to it.

:class:`SessionTail` wraps :class:`sessions.SessionFollower` (HDF5's SWMR
read mode, bounded metadata retries) with what a viewer that runs for
hours needs:

* **it never writes**: the file is opened read-only (SWMR read, or a plain
  read-only open for the header), and whether a writer is alive is asked
  of the kernel's lock table on a read-only descriptor;
* **it survives the file's life**: before the writer has laid the file out,
  while it runs, after it finished, failed or was killed, and when the path
  is renamed over by a new file -- ``rig acquire --resume`` and storing a
  model both rewrite a session into a checked copy -- the tail opens the
  new file and carries on;
* **it is incremental**: each :meth:`poll` reads only the rows flushed
  since the last one, so following a 20,000-sample session costs the same
  per poll as a short one.

Problems reading the file (gone, replaced by something that is not a
session, torn) are kept as :attr:`error` text for the page, never raised:
the last good data stay on show.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sessions import DataFileError, Session, SessionFollower, read_session
from sessions.records import Event
from sessions.schema import SAMPLE_DTYPE, Status


class SessionTail:
    """The samples, log and header of one session, kept up to date by :meth:`poll`.

    ``samples`` is a :data:`~sessions.schema.SAMPLE_DTYPE` array of every
    row flushed so far; ``header`` the :class:`~sessions.Session` read when
    the file was (re)opened (quantities, excitation plan, models, ...);
    ``events`` the log; ``generation`` counts the files followed (it grows
    when a rewrite replaced the file); ``writer_alive`` whether a process
    holds the writer's lock (asked only while the status is ``running``).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.header: Session | None = None
        self.events: tuple[Event, ...] = ()
        self.error: str | None = None
        self.generation = 0
        self.writer_alive = False
        self._follower: SessionFollower | None = None
        self._rows = np.empty(64, SAMPLE_DTYPE)
        self._n = 0

    # ------------------------------------------------------------ reading
    @property
    def samples(self) -> np.ndarray:
        """Every sample row seen so far, ``(n,)`` (a view: copy it to keep it)."""
        return self._rows[: self._n]

    @property
    def n_samples(self) -> int:
        return self._n

    @property
    def status(self) -> Status | None:
        return self.events[-1].status if self.events else None

    def poll(self) -> bool:
        """Read what was flushed since the last call; True when anything the page shows changed."""
        before = (self._n, len(self.events), self.events[-1] if self.events else None, self.error,
                  self.generation, self.writer_alive)
        try:
            if self._follower is not None and self._follower.replaced():
                self._close()
            if self._follower is None:
                self._open()
            else:
                self._append(self._follower.poll())
                self.events = self._follower.events
            self.error = None
        except (DataFileError, OSError, RuntimeError, KeyError, ValueError) as exc:
            self._close()
            self.error = str(exc) or type(exc).__name__
        alive = False
        if self.status is Status.RUNNING and self.error is None:
            alive = self.header is not None and self.header.writer_alive()
        self.writer_alive = alive
        after = (self._n, len(self.events), self.events[-1] if self.events else None, self.error,
                 self.generation, self.writer_alive)
        return after != before

    def _open(self) -> None:
        header = read_session(self.path)  # validates, with the clear one-line errors
        follower = SessionFollower(self.path)
        try:
            rows = follower.poll()
            events = follower.events
        except BaseException:
            follower.close()
            raise
        self._follower, self.header, self.events = follower, header, events
        self.generation += 1
        self._n = 0
        self._append(rows)

    def _append(self, rows: np.ndarray) -> None:
        k = rows.size
        if not k:
            return
        if self._n + k > self._rows.size:
            grown = np.empty(max(2 * self._rows.size, self._n + k), SAMPLE_DTYPE)
            grown[: self._n] = self._rows[: self._n]
            self._rows = grown
        self._rows[self._n : self._n + k] = rows
        self._n += k

    def _close(self) -> None:
        if self._follower is not None:
            try:
                self._follower.close()
            finally:
                self._follower = None

    def close(self) -> None:
        self._close()

    def __enter__(self) -> "SessionTail":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def wait_readable(path: Path, timeout_s: float = 3.0) -> Session:
    """Read ``path`` as a session; while its writer is still laying it out (HDF5 holds the file locked
    until the writer switches to SWMR mode) retry for up to ``timeout_s``.  Any other problem, or the
    lock outlasting the wait, raises :class:`~sessions.DataFileError` at once."""
    end = time.monotonic() + timeout_s
    while True:
        try:
            return read_session(path)
        except DataFileError as exc:
            if "locked by a program that is writing it" not in str(exc) or time.monotonic() >= end:
                raise
        time.sleep(0.05)


def session_summary(path: Path) -> dict:
    """What a directory's index shows of one file, read cheaply (header and log only, read-only):
    ``status``, ``n_samples`` (rows the table holds), ``n_points`` planned, or ``error``."""
    from sessions.reader import check_header, open_hdf5, read_events

    try:
        with open_hdf5(path) as f:
            check_header(path, f)
            events = read_events(f["log"])
            return {"status": events[-1].status.value, "n_samples": int(f["samples"].shape[0]),
                    "n_points": int(f["excitation/inputs"].shape[0]), "error": None}
    except (DataFileError, OSError, KeyError, RuntimeError, ValueError) as exc:
        return {"status": None, "n_samples": None, "n_points": None, "error": str(exc) or type(exc).__name__}
