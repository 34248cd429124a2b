"""Bounded work: the size and cost of a long job, stated before it starts, refused above documented limits.

``rig acquire --levels 10000`` once started a 50-million-point plan (years
of rig time) and ``rig identify --levels 10000`` ran for minutes at 4 GB,
both without a word.  Each command now estimates its job first
(:mod:`rig.budget.acquisition`, :mod:`rig.budget.identification`), says
what it will cost, and refuses a job above the limits documented there
(docs/reference/limits.md) unless the user confirms with ``--yes``.
"""

from __future__ import annotations

from .limits import Exceeded, format_bytes, format_duration, refuse_unless_confirmed

__all__ = ["Exceeded", "format_bytes", "format_duration", "refuse_unless_confirmed"]
