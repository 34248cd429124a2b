"""Hold Ctrl-C (and SIGTERM) back while a sample is written (after QCoDeS' DelayedKeyboardInterrupt).

A SIGINT -- or a SIGTERM, when a Python handler owns it (a command that
turns it into an abort) -- arriving inside :func:`deferred_interrupt` is
remembered and delivered, to whatever handler was installed before, when
the block ends; so an append is either fully in the file and counted, or
not started.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def deferred_interrupt() -> Iterator[None]:
    """Delay SIGINT (and a Python-handled SIGTERM) until the end of the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    # a handler installed outside Python (None) is left alone; SIGTERM only when Python handles it
    owned = {s: h for s, h in previous.items()
             if h is not None and (s == signal.SIGINT or callable(h))}
    received: list[tuple[int, object]] = []
    for s in owned:
        signal.signal(s, lambda sig, frame: received.append((sig, frame)))
    try:
        yield
    finally:
        for s, h in owned.items():
            signal.signal(s, h)
        for sig, frame in received:  # in order; the first handler that raises ends it
            handler = owned[sig]
            if callable(handler):
                handler(sig, frame)
            elif handler == signal.SIG_DFL:
                raise KeyboardInterrupt
