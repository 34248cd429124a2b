"""A limit a job's estimate exceeds, the refusal that names it, and sizes written for people."""

from __future__ import annotations

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


def format_seconds(seconds: float) -> str:
    """A duration to the precision an estimate has: ``0.3 s``, ``12 s``, ``4.2 min``, ``2.6 h``, ``31 days``,
    ``32 years``."""
    s = float(seconds)
    if s < 10:
        return f"{s:.2g} s"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if s >= 2 * size if unit in ("years", "days") else s >= size:
            value = s / size
            return f"{value:.2g} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{s:.0f} s"


def format_bytes(n: float) -> str:
    """``512 kB``, ``3.2 MB``, ``4.1 GB`` (decimal units)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            value = n / size
            return f"{value:.2g} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{n:.0f} B"
