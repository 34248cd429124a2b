"""Signals around the few places where an interrupt could lose data or leave the heater on.

The ground floor under :mod:`drivers` and :mod:`sessions` (it imports
neither, and nothing of this project):

* :func:`delay_keyboard_interrupt` -- the one interrupt guard.  A Ctrl-C (or
  a SIGTERM, when a Python handler owns it) that arrives while an
  instrument transaction is on the wire or a sample is being appended is
  held until the block is complete -- the link is never left with a
  half-read reply, a session never with a half-written row -- then handed,
  in the order they came, to the handler that was there before.  Every
  signal is held, a second one too: a transaction is bounded by its
  timeouts and retries, an append by the disk, and the way to the safe
  state must not be cut short.  Modelled on QCoDeS'
  ``DelayedKeyboardInterrupt``.  It prints nothing: whoever handles the
  signal when it is delivered says what happens (``rig acquire``'s pause
  switch, the command's "interrupted").
* :func:`terminate_as_interrupt` -- SIGTERM raises :class:`KeyboardInterrupt`,
  so ``kill PID`` goes through the same ``finally`` blocks (heater to 0 V)
  as Ctrl-C -- once: further SIGTERMs inside the block are ignored, so a
  burst of them cannot interrupt the way to the safe state.  Installed by
  commands, never by library code on its own.

Signals are always handed on to the handler that was installed before
(never turned into a ``KeyboardInterrupt`` here), so a handler that ignores
repeated signals -- ``rig acquire``'s pause switch once an abort has
started -- keeps ignoring them.  A signal whose handler is not a Python
function (the default action, ignored, or set outside Python) is left alone.

Signal handlers can only be installed from the main thread; elsewhere both
guards do nothing.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["delay_keyboard_interrupt", "terminate_as_interrupt"]


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def delay_keyboard_interrupt() -> Iterator[None]:
    """Hold SIGINT (and SIGTERM, when a Python handler owns it) until the block ends, then deliver every
    signal held, in order, to the handler that was there before (the first that raises ends it)."""
    if not _main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    owned = {s: h for s, h in previous.items() if callable(h)}  # SIG_DFL/SIG_IGN/None: left alone
    received: list[tuple[int, FrameType | None]] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        received.append((signum, frame))

    for s in owned:
        signal.signal(s, hold)
    try:
        yield
    finally:
        for s, h in owned.items():
            signal.signal(s, h)
        for signum, frame in received:
            owned[signum](signum, frame)


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, the first SIGTERM raises :class:`KeyboardInterrupt`; later ones are ignored.

    The old handler returns when the block ends.
    """
    if not _main_thread():
        yield
        return
    fired: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        if fired:
            return
        fired.append(signum)
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
