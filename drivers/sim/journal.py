"""What the simulated bench received, recorded server-side, for tests and for the operator.

Every set-point request is recorded *as decoded by the server*, accepted or
not, so a test can assert that no out-of-limit value ever reached the
instrument -- checked where it would matter, at the far end of the wire.

With a ``sink`` (``rig serve-sim --journal FILE``) every entry is also
written at once as one JSON line, so another process -- a fault-injection
test that kills, stops or restarts the server -- can read what the heater
saw, up to the moment the server died::

    {"t_unix": 1767.2, "event": "start", "pid": 4711, "boot_id": 2864434397, "endpoints": {...}}
    {"t_unix": 1767.3, "event": "setpoint", "transport": "modbus", "volts": 4.0, "accepted": true, "detail": ""}
    {"t_unix": 1769.9, "event": "stop", "heater_V": 0.0}

Lines are written with one ``write`` each and flushed; a reader ignores a
torn last line (:func:`read_journal`).
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
from dataclasses import dataclass, field
from typing import IO, Any


@dataclass(frozen=True)
class SetpointRequest:
    """One request to change the heater voltage, as the server saw it."""

    transport: str
    volts: float
    accepted: bool
    detail: str = ""


#: Beyond this many entries the oldest half of a list is dropped (a long serve-sim session).
JOURNAL_LIMIT = 200_000


def _trim(entries: list) -> None:
    if len(entries) > JOURNAL_LIMIT:
        del entries[: JOURNAL_LIMIT // 2]


def _finite_or_text(x: float) -> float | str:
    return x if math.isfinite(x) else repr(x)  # JSON has no NaN; "nan", "inf" say what arrived


@dataclass
class Journal:
    """Set-point requests and raw command lines received by the servers (oldest first).

    ``sink``: an open text file that gets every set-point request and every
    :meth:`event` as one JSON line, flushed at once.
    """

    setpoints: list[SetpointRequest] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)
    sink: IO[str] | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def setpoint(self, transport: str, volts: float, accepted: bool, detail: str = "") -> None:
        with self._lock:
            self.setpoints.append(SetpointRequest(transport, volts, accepted, detail))
            _trim(self.setpoints)
            self._emit({"event": "setpoint", "transport": transport, "volts": _finite_or_text(float(volts)),
                        "accepted": bool(accepted), "detail": detail})

    def line(self, text: str) -> None:
        with self._lock:
            self.lines.append(text)
            _trim(self.lines)

    def event(self, name: str, **fields: Any) -> None:
        """A server event (``start``, ``stop``, ...) for the sink; nothing is kept in memory."""
        with self._lock:
            self._emit({"event": name, **fields})

    def volts_received(self) -> list[float]:
        """Every set-point value that arrived, accepted or refused."""
        with self._lock:
            return [r.volts for r in self.setpoints]

    def _emit(self, entry: dict[str, Any]) -> None:
        if self.sink is None:
            return
        self.sink.write(json.dumps({"t_unix": time.time(), **entry}) + "\n")
        self.sink.flush()


def open_journal_file(path: str | os.PathLike) -> IO[str]:
    """``path`` opened for appending JSON lines (line-buffered, so each entry is one write)."""
    return open(path, "a", encoding="utf-8", buffering=1)


def read_journal(path: str | os.PathLike) -> list[dict[str, Any]]:
    """The entries of a journal file, oldest first; a torn last line (the server was killed) is ignored."""
    entries = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if not line.endswith("\n"):
                break
            entries.append(json.loads(line))
    return entries
