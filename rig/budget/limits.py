"""A limit a job's estimate exceeds, the refusal that names it, and sizes written for people."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import UserError


@dataclass(frozen=True)
class Exceeded:
    """One estimate over its limit: ``what`` (``"rig time"``) and both values as text."""

    what: str
    estimate: str
    limit: str

    def __str__(self) -> str:
        return f"{self.what} {self.estimate} (limit {self.limit})"


def refuse_unless_confirmed(job: str, exceeded: list[Exceeded], yes: bool) -> None:
    """Refuse ``job`` (one line, exit 2) when an estimate is over its limit, unless ``yes``."""
    if exceeded and not yes:
        raise UserError(f"{job}: {'; '.join(map(str, exceeded))}; nothing was started -- reduce the job, "
                        "or add --yes to run it anyway")


def format_duration(seconds: float) -> str:
    """A duration, in the one convention every ``rig`` message uses (plans, limits, progress, summaries):
    ``0.012 s`` and ``42 s`` under a minute, ``2:35:40`` (H:MM:SS) under a day, ``837 d 14:00:00`` beyond."""
    s = float(seconds)
    if not math.isfinite(s):
        return f"{s} s"
    if abs(s) < 59.5:
        return f"{s:.2g} s" if abs(s) < 10 else f"{s:.0f} s"
    whole = int(round(s))
    days, rest = divmod(whole, 86400)
    clock = f"{rest // 3600}:{rest // 60 % 60:02d}:{rest % 60:02d}"
    return clock if days == 0 else f"{days} d {rest // 3600:02d}:{rest // 60 % 60:02d}:{rest % 60:02d}"


def format_bytes(n: float) -> str:
    """``512 kB``, ``3.2 MB``, ``4.1 GB`` (decimal units)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            value = n / size
            return f"{value:.2g} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{n:.0f} B"
