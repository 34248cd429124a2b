"""How a blind benchmark scores a verdict: four columns, the library's nesting, and the oracle.

Shared by every generator's runner (``benchmarks.blind.run`` for the
generators written from ``SPEC.md``, ``benchmarks.withheld.run`` for the
project's own), so that a table means the same whichever generator made it.

* **right** -- a library mechanism named alone; two named exactly; ``no_gap``
  on a clean device; an outside mechanism left ``unexplained``,
  ``ambiguous`` or ``cannot_tell``;
* **honest** -- ``ambiguous`` naming the true mechanism among at most two
  rivals, when the oracle says the run cannot tell them apart either;
* **open** -- ``unexplained``, ``cannot_tell``, ``no_gap`` where there is a
  gap, one of two mechanisms named, or an ambiguity the run could resolve;
* **wrong** -- any name that is not the truth's.

A name is the truth's when it is the same mechanism or the library's
declared special case of it, or the other way round (``joule_power`` of
``reversible``, :attr:`identify.effects.Effect.within`): the verdict then
names the form the mechanism took.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

COLUMNS = ("right", "honest", "open", "wrong")
#: Paired z below which the oracle cannot tell the true signal from a rival: the run cannot either.
ORACLE_Z = 2.0


def _nesting() -> dict[str, str]:
    """The library's own declaration of which effect is a special case of which (``Effect.within``)."""
    from identify.effects import EFFECTS

    return {n: c.within for n, c in EFFECTS.items() if c.within}


def same_mechanism(named: str, true: str) -> bool:
    """``named`` is ``true``, or one is the library's declared special case of the other."""
    nest = _nesting()
    return named == true or nest.get(named) == true or nest.get(true) == named


def classify(kind: str, truth: list[str], verdict: dict[str, Any], honest: bool = False) -> str:
    """``right``, ``honest``, ``open`` or ``wrong`` for a case of ``kind`` (``library``, ``outside``,
    ``none``, ``pair``) whose true mechanisms are ``truth``, from the verdict's ``status`` and ``effects``;
    ``honest``: the oracle says the run cannot tell the ambiguous rivals apart."""
    status = verdict.get("status")
    named = [next((t for t in truth if same_mechanism(n, t)), n) for n in verdict.get("effects") or []]
    if status == "explained" and any(n not in truth for n in named):
        return "wrong"
    if kind == "none":
        return "right" if status == "no_gap" else "open"
    if kind == "outside":
        return "right" if status in ("unexplained", "ambiguous", "cannot_tell") else "open"
    if kind == "library":
        if status == "explained" and named == truth:
            return "right"
        return "honest" if honest else "open"
    if status == "explained" and sorted(named) == sorted(truth):
        return "right"
    return "open"


def wants_oracle(kind: str, truth: list[str], verdict: dict[str, Any]) -> str | None:
    """The rival to test the true signal against: an ambiguous verdict on one library mechanism that names
    it among at most two rivals (None otherwise)."""
    rivals = list(verdict.get("rivals") or [])
    if kind != "library" or verdict.get("status") != "ambiguous" or len(rivals) > 2:
        return None
    hits = [r for r in rivals if same_mechanism(r, truth[0])]
    others = [r for r in rivals if r not in hits]
    return others[0] if hits and others else None


def named_outside(kind: str, verdict: dict[str, Any]) -> list[str]:
    """The library names an outside mechanism was given (an ``explained`` verdict on an ``outside`` case),
    to score the mechanism's own signal against: whether the runs held the evidence that the name is not the
    mechanism, for a candidate of the mechanism's form (empty otherwise)."""
    if kind != "outside" or verdict.get("status") != "explained":
        return []
    return list(verdict.get("effects") or [])


def oracle_separation(fit: Path, check: Path, signals: list[np.ndarray], rival: str) -> float:
    """Paired z of the true signal's held-out gain over ``rival``'s: the noise-free difference the
    mechanism makes (``signals``: identification run, then check run) as one more candidate of one
    coefficient (``benchmarks.withheld.oracle.oracle_effect``), by the same diagnosis on the sessions."""
    from benchmarks.withheld.oracle import oracle_effect
    from identify.diagnosis import DiagnosisSettings, diagnose, library
    from identify.diagnosis.resolution import Resolution
    from identify.diagnosis.verdict import _ratio
    from rig.diagnosis.loading import load_runs

    loaded = load_runs([fit], [check])
    cands = [*library(), Resolution(loaded.grid, tuple(loaded.fit), tuple(loaded.check)),
             oracle_effect("oracle", tuple(np.asarray(s, dtype=float) for s in signals))]
    d = diagnose(loaded.fit, loaded.check, loaded.grid, DiagnosisSettings(keep=False), candidates=cands)
    ev = d.evidence
    i, j = ev.names.index("oracle"), ev.names.index(rival)
    return float(_ratio(ev.gain[i] - ev.gain[j], ev.difference_se(i, j)))


def four_columns(rows: list[tuple[str, str, str]]) -> dict[str, Any]:
    """Counts of each column per case label (pairs together) and per kind, from ``(kind, label, column)``
    rows; a column outside :data:`COLUMNS` (``skipped``, ``error``) is counted but left out of the totals."""
    by: dict[str, dict[str, int]] = {}
    for kind, label, column in rows:
        key = label if kind in ("library", "outside", "none") else "pairs"
        group = by.setdefault(key, {c: 0 for c in (*COLUMNS, "skipped", "error")})
        group[column] = group.get(column, 0) + 1
    totals = {}
    for kind in ("library", "outside", "none", "pair"):
        sub = [c for k, _, c in rows if k == kind and c in COLUMNS]
        totals[kind] = {c: sub.count(c) for c in COLUMNS} | {"n": len(sub)}
    return {"by_family": by, "totals": totals}


def print_four_columns(t: dict[str, Any], out: Any = None) -> None:
    """The table of :func:`four_columns`, one line a case label, then a line a kind with its rates."""
    import sys

    out = out or sys.stdout
    print(f"{'case':26s} {'right':>6s} {'honest':>7s} {'open':>5s} {'wrong':>6s} {'skip':>5s} {'error':>6s}", file=out)
    for k, g in t["by_family"].items():
        print(f"{k:26s} {g['right']:6d} {g['honest']:7d} {g['open']:5d} {g['wrong']:6d} {g.get('skipped', 0):5d} "
              f"{g.get('error', 0):6d}", file=out)
    print("", file=out)
    for kind, tt in t["totals"].items():
        n = max(tt["n"], 1)
        print(f"{kind:8s} n={tt['n']:4d}  right {tt['right']:4d} ({100 * tt['right'] / n:5.1f} %)  "
              f"right+honest {100 * (tt['right'] + tt['honest']) / n:5.1f} %  open {tt['open']:4d}  "
              f"wrong {tt['wrong']:3d} ({100 * tt['wrong'] / n:4.1f} %)", file=out)
