"""Simulated identification and check runs with an unmodelled effect switched on.

Both runs go through the real acquisition sequencer (:func:`rig.acquisition.acquire`)
on the in-process simulated device and its virtual clock, into real
session files -- the path an operator's runs take, minus the hardware.
The identification run is the damped oscillation of the grid with the
thermal point at a fixed dwell; the check run is ``rig acquire --sequence
check`` (:func:`identify.diagnosis.check_design`) with its per-point dwells.  Each
run is a new power-on of the device with its own seeds (noise, drift
realisation), as two runs on a bench are.

Used by ``rig demo`` (through :mod:`rig.diagnosis.demo`) and by
``benchmarks/diagnose_bench.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivers import default_config, open_rig
from drivers.sim import EFFECTS
from identify import Excitation, Grid
from rig.acquisition import DwellSettings, FixedDwell, Transit, acquire, make_record, sequence_dwells, sequence_record
from sessions import ExcitationRecord

#: Dwell of the identification run (s): 40 of the device's 0.5 s time constants.
FIT_DWELL_S = 20.0
#: Readings averaged per measurement.
READINGS = 4
#: The check design of simulated run ``seed`` is seeded with this plus ``seed``.
CHECK_SEED = 1000


@dataclass(frozen=True)
class SimulatedBench:
    """What to simulate: the device (``sim`` overrides of :class:`drivers.sim.SimParams`), the grid
    ``levels``, the effect (``None``: none) with its ``strength`` and extra ``params``, the check
    design's length, and the base ``seed`` (run ``k`` uses ``2 seed + k`` for noise and drifts)."""

    effect: str | None = None
    strength: float = 0.0
    params: dict[str, float] = field(default_factory=dict)
    levels: int = 30
    check_points: int = 200
    seed: int = 0
    sim: dict[str, Any] = field(default_factory=dict)
    noise: bool = True

    def effects_table(self, run: int) -> dict[str, Any]:
        """``[sim.effects]`` for run ``run`` (0: identification, 1: check)."""
        if self.effect is None or self.strength == 0:
            return {}
        spec: dict[str, Any] = {"strength": float(self.strength), **self.params}
        if "seed" in EFFECTS[self.effect].parameters:
            spec["seed"] = float(2 * self.seed + run)
        return {self.effect: spec}

    def config(self, run: int):
        sim = dict(self.sim)
        if not self.noise:
            sim["psd_noise_V"] = 0.0
        return default_config(levels=self.levels, seed=2 * self.seed + run, effects=self.effects_table(run), **sim)

    def grid(self) -> Grid:
        cfg = self.config(0)
        return Grid(self.levels, cfg.sim.v_min_V, cfg.sim.v_max_V)


def _run(bench: SimulatedBench, run: int, record: ExcitationRecord, settings: DwellSettings, path: Path) -> Path:
    with open_rig(bench.config(run)) as rig:
        outcome = acquire(rig, record, path, settings=settings, fsync_interval_s=None,
                          operator="simulation", notes=f"simulated run {run}: {bench.effects_table(run) or 'no effect'}")
    if outcome.status.value != "complete":
        raise RuntimeError(f"simulated run {path} ended {outcome.status.value}: {outcome.message}")
    return path


def simulate_fit_run(bench: SimulatedBench, path: str | Path) -> Path:
    """The identification run (damped oscillation + thermal point, fixed dwell) into ``path``."""
    settings = DwellSettings(FixedDwell(FIT_DWELL_S), Transit(0.0), READINGS)
    record = make_record(ExcitationRecord.from_excitation(Excitation.damped(bench.grid(), True)), settings)
    return _run(bench, 0, record, settings, Path(path))


def simulate_check_run(bench: SimulatedBench, path: str | Path) -> Path:
    """The check run (``rig acquire --sequence check``: random reversals, several steps and dwells,
    repeats) into ``path``."""
    g = bench.grid()
    window = bench.config(1).heater.limits().window
    args = dict(levels=g.levels, v_min=g.v_min, v_max=g.v_max, points=bench.check_points, seed=CHECK_SEED + bench.seed)
    schedule = sequence_dwells("check", window, **args)
    settings = DwellSettings(FixedDwell(float(np.max(schedule))), Transit(0.0), READINGS, tuple(schedule))
    record = make_record(sequence_record("check", window, **args), settings)
    return _run(bench, 1, record, settings, Path(path))


def simulate(bench: SimulatedBench, directory: str | Path) -> tuple[Path, Path]:
    """Both runs into ``directory`` (``fit.h5``, ``check.h5``); returns their paths."""
    d = Path(directory)
    return simulate_fit_run(bench, d / "fit.h5"), simulate_check_run(bench, d / "check.h5")
