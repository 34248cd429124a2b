"""Retrying a transaction with reconnection and exponential back-off.

Only transactions that are safe to repeat are retried: reads, and writes of
an absolute set-point (writing "1.25 V" twice leaves the heater at 1.25 V).
Between attempts the link is closed and reopened after a wait that starts
at ``backoff_s`` and doubles up to ``backoff_max_s`` (:class:`LinkConfig`,
the keys the Modbus and serial tables share).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from .configschema import setting
from .errors import ConnectionFailed, DriverError, DriverTimeout, ProtocolError

T = TypeVar("T")


@dataclass(frozen=True, kw_only=True)
class LinkConfig:
    """Timeouts and reconnection shared by the Modbus and serial links."""

    timeout_s: float = setting("time to wait for a reply", default=1.0, unit="s", positive=True)
    retries: int = setting(
        "extra attempts after a timeout or a dropped link (reconnecting in between)", default=3, minimum=0, maximum=100
    )
    backoff_s: float = setting("wait before the first reconnection; doubles each time", default=0.1, unit="s", minimum=0.0)
    backoff_max_s: float = setting("longest wait between reconnections", default=2.0, unit="s", minimum=0.0)


class LinkDropped(Exception):
    """Internal: the link is down (refused, reset, closed); reconnect and retry."""


class NoReply(Exception):
    """Internal: no (complete) reply in time; reconnect to discard late bytes and retry."""


class BadReply(Exception):
    """Internal: an unusable reply to a read; retrying the read is safe."""


@dataclass(frozen=True)
class Backoff:
    """``retries`` extra attempts; waits ``first_s``, ``2 first_s``, ... capped at ``max_s``."""

    retries: int
    first_s: float
    max_s: float

    def delays(self) -> list[float]:
        """The wait before each retry, in order (length ``retries``)."""
        return [min(self.first_s * 2**k, self.max_s) for k in range(self.retries)]


def with_retries(
    attempt: Callable[[], T],
    *,
    reconnect: Callable[[], None],
    backoff: Backoff,
    what: str,
    sleep: Callable[[float], None] = time.sleep,
    on_failure: Callable[[], None] | None = None,
) -> T:
    """Run ``attempt`` until it succeeds; on a dropped link, a timeout or a bad reply, reconnect and retry.

    ``on_failure`` is called once per failed attempt (the link counts them, so
    that a reading which needed a retry is flagged as such).

    Raises :class:`ConnectionFailed`, :class:`DriverTimeout` or
    :class:`ProtocolError` (after the last failure's kind) naming ``what``
    once the retries are spent.  Errors other than the three internal
    ones propagate at once.
    """
    last: Exception | None = None
    for delay in [None, *backoff.delays()]:
        if delay is not None:
            sleep(delay)
            try:
                reconnect()
            except LinkDropped as exc:
                last = exc
                continue
        try:
            return attempt()
        except (LinkDropped, NoReply, BadReply) as exc:
            last = exc
            if on_failure is not None:
                on_failure()
    tries = backoff.retries + 1
    if isinstance(last, NoReply):
        raise DriverTimeout(f"{what}: no reply after {tries} attempt(s): {last}")
    if isinstance(last, BadReply):
        carried = last.args[0] if last.args else None
        if isinstance(carried, DriverError):  # e.g. a Modbus "busy" that never cleared
            carried.add_note(f"(after {tries} attempt(s))")
            raise carried
        raise ProtocolError(f"{what}: {last} (after {tries} attempt(s))")
    raise ConnectionFailed(f"{what}: {last} (after {tries} attempt(s))")
