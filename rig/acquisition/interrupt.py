"""Ctrl-C during an acquisition: once pauses at a safe point, twice aborts; SIGTERM aborts.

:class:`PauseSwitch` owns SIGINT and SIGTERM while a run is in progress.
The first Ctrl-C only *requests* a pause: the sequencer notices it at its
next safe point -- before applying a set-point, or between two slices of a
dwell -- holds the heater at the current set-point, logs ``paused`` and
asks its ``on_pause`` callback whether to resume or abort.  A Ctrl-C while
a pause is pending or being decided, or a SIGTERM, raises
:class:`KeyboardInterrupt` at once: the run is aborted (the guard around
instrument transactions and session appends still lets those finish first,
see :mod:`interrupts`).  It is raised once:
every later signal is ignored while the program goes to the safe state.

:class:`Aborted` is how a decided abort travels: a :class:`KeyboardInterrupt`,
so every layer that puts the heater at 0 V on Ctrl-C does so for it too.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType
from typing import Literal

Decision = Literal["resume", "abort"]


class Aborted(KeyboardInterrupt):
    """The operator chose to abort the run (at the pause prompt, or with a second Ctrl-C)."""


@dataclass(frozen=True)
class PauseInfo:
    """Where a run paused: at point ``index`` of ``n_points`` (0-based), heater held at ``setpoint_V``.

    ``phase`` is ``"before point"`` (the set-point of ``index`` is not applied
    yet), ``"dwell"`` (waiting at ``index``; its dwell restarts on resume)
    or ``"replay"`` (restoring the memory state of a resumed session).
    """

    index: int
    n_points: int
    setpoint_V: float
    phase: str


class PauseSwitch:
    """Owns SIGINT and SIGTERM while a run is in progress.

    The first SIGINT (or :meth:`request`) asks for a pause; a SIGINT while a
    pause is pending, or any SIGTERM, aborts: :class:`Aborted` is raised --
    **once**.  From the moment an abort starts (by a signal, or by
    :meth:`abort` when the operator chose it) every further SIGINT and
    SIGTERM is counted in :attr:`ignored` and otherwise ignored, so that any
    number of them cannot interrupt the way to the safe state (heater to
    0 V, session closed ``aborted``).
    """

    def __init__(self) -> None:
        self._pending = False
        self._aborting = False
        #: Signals that arrived after the abort had started (ignored).
        self.ignored = 0

    @property
    def requested(self) -> bool:
        return self._pending

    @property
    def aborting(self) -> bool:
        return self._aborting

    def request(self) -> None:
        """Ask for a pause at the next safe point (what the first Ctrl-C does)."""
        self._pending = True

    def clear(self) -> None:
        """The pause is over (the run continues); the next Ctrl-C asks for a pause again."""
        self._pending = False

    def abort(self, message: str) -> Aborted:
        """Start the abort (further signals are ignored from now on); returns the exception to raise."""
        self._aborting = True
        return Aborted(message)

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self._aborting:
            self.ignored += 1
            return
        if signum == signal.SIGINT and not self._pending:
            self._pending = True
            return
        raise self.abort("terminated (SIGTERM)" if signum == signal.SIGTERM else "interrupted twice (Ctrl-C)")

    @contextmanager
    def installed(self, *, linger: bool = False) -> Iterator["PauseSwitch"]:
        """Own SIGINT and SIGTERM for the block (main thread only; elsewhere they keep their usual meaning).

        With ``linger``, once an abort has started the signals stay ignored
        after the block too -- for a command on its way out, where a late
        signal of a burst must not kill the process between the safe state
        and its exit code.
        """
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        old = {s: signal.signal(s, self._handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield self
        finally:
            for s, handler in old.items():
                signal.signal(s, signal.SIG_IGN if linger and self._aborting else handler)
