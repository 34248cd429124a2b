"""Guards around the few places where an interrupt could leave the heater on.

* :func:`delay_keyboard_interrupt` -- a Ctrl-C (or a SIGTERM turned into
  one) that arrives while a set-point transaction is on the wire is held
  until the transaction is complete (the link is never left with a
  half-read reply), then handed to the handler that was there before.  A
  second one is handed on at once (the operator insists).  Modelled on
  QCoDeS' ``DelayedKeyboardInterrupt``.
* :func:`terminate_as_interrupt` -- SIGTERM raises :class:`KeyboardInterrupt`,
  so ``kill PID`` goes through the same ``finally`` blocks (heater to 0 V)
  as Ctrl-C -- once: further SIGTERMs inside the block are ignored, so a
  burst of them cannot interrupt the way to the safe state.  Installed by
  commands, never by library code on its own.

Signals are always handed on to the handler that was installed before
(never turned into a ``KeyboardInterrupt`` here), so a handler that ignores
repeated signals -- :class:`rig.acquisition.PauseSwitch` once an abort has
started -- keeps ignoring them inside these guards too.

Signal handlers can only be installed from the main thread; elsewhere both
guards do nothing.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def delay_keyboard_interrupt() -> Iterator[None]:
    """Hold SIGINT (and SIGTERM, when a Python handler owns it) until the block ends, then deliver it.

    A second signal during the block is delivered at once.
    """
    if not _main_thread():
        yield
        return
    olds = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    olds = {s: h for s, h in olds.items() if callable(h)}  # SIG_DFL/SIG_IGN/None: leave alone
    received: list[tuple[int, FrameType | None]] = []

    def restore() -> None:
        for s, h in olds.items():
            signal.signal(s, h)

    def handler(signum: int, frame: FrameType | None) -> None:
        if received:  # second signal: the operator insists
            restore()
            olds[signum](signum, frame)
            return
        received.append((signum, frame))
        print("Interrupt received: finishing the instrument transaction first.", file=sys.stderr)

    for s in olds:
        signal.signal(s, handler)
    try:
        yield
    finally:
        restore()
        if received:
            signum, frame = received[0]
            olds[signum](signum, frame)


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
