"""A whole diagnosis on the simulated bench in one call -- what ``rig demo`` ends with.

:func:`diagnose_simulated` records an identification run and a check run
with one unmodelled effect switched on (through the real sequencer, into
sessions), fits the base model without it and runs the diagnosis blind;
it returns the diagnosis with its readable report and ``--json`` object.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.sim import EFFECTS
from identify.diagnosis import Diagnosis, DiagnosisSettings, diagnose

from .loading import load_runs
from .report import to_json, to_text
from .simulate import SimulatedBench, simulate

def demo_strength(effect: str | None) -> float:
    """The strength the demo switches ``effect`` on with (0 for none): the simulated effect's own
    (:attr:`drivers.sim.Effect.demo_strength`), a gap about ten times the noise on the default bench."""
    return EFFECTS[effect].demo_strength if effect in EFFECTS else 0.0


#: The effect the demo switches on unless told otherwise.
DEMO_EFFECT = "creep"


@dataclass(frozen=True, eq=False)
class SimulatedDiagnosis:
    """The effect switched on and its strength, the two sessions, the diagnosis and its reports."""

    effect: str | None
    strength: float
    fit_path: Path
    check_path: Path
    diagnosis: Diagnosis
    text: str
    json: dict[str, Any]


def diagnose_simulated(
    effect: str | None = DEMO_EFFECT,
    strength: float | None = None,
    *,
    seed: int = 0,
    directory: str | Path | None = None,
    levels: int = 30,
    check_points: int = 200,
) -> SimulatedDiagnosis:
    """Simulate both runs with ``effect`` on (None: no effect) and diagnose them blind.

    ``strength`` defaults to :func:`demo_strength`; the sessions are
    written to ``directory`` (default: a temporary directory, removed
    afterwards -- the returned paths then no longer exist).  A few seconds
    on the virtual clock.
    """
    if strength is None:
        strength = demo_strength(effect)
    bench = SimulatedBench(effect, strength, levels=levels, check_points=check_points, seed=seed)
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(directory) if directory is not None else Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        fit, check = simulate(bench, where)
        result, text, obj = diagnose_sessions(fit, check)
    return SimulatedDiagnosis(effect, float(strength), fit, check, result, text, obj)


def diagnose_sessions(fit: Path, check: Path, settings: DiagnosisSettings | None = None
                      ) -> tuple[Diagnosis, str, dict[str, Any]]:
    """Diagnose one identification and one check session; the diagnosis, its report and ``--json`` object
    (the sessions are named by file name)."""
    loaded = load_runs([fit], [check])
    result = diagnose(loaded.fit, loaded.check, loaded.grid, settings or DiagnosisSettings())
    names = ([fit.name], [check.name])
    return result, to_text(result, *names, loaded.warnings), to_json(result, *names, loaded.warnings)
