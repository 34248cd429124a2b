"""Identification and check runs of a withheld device, through the real sequencer.

The runs are those of ``rig/diagnosis/simulate.py`` (and of an operator):
the identification run is the damped oscillation of the grid plus the
thermal point at a fixed 20 s dwell, the check run ``rig acquire --sequence
check`` with its per-point dwells; ``K = 4`` readings averaged per point;
each run is a new power-on of the device (its own noise seed, its own
drift realisation) on a virtual clock.

:func:`record_run` writes the session through :func:`rig.acquisition.acquire`;
:func:`noise_free_outputs` drives the same :class:`~rig.acquisition.engine.Sequencer`
with an in-memory recorder -- the same calls on the device in the same
order, without the file -- for the calibration's many noise-free runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivers import default_config, open_rig
from drivers.config import RigConfig
from identify import Excitation, Grid
from rig.acquisition import (
    DwellSettings,
    FixedDwell,
    Transit,
    acquire,
    make_record,
    sequence_dwells,
    sequence_record,
)
from rig.acquisition.engine import Sequencer
from rig.acquisition.plan import AcquisitionPlan
from rig.diagnosis.simulate import FIT_DWELL_S, READINGS
from sessions import ExcitationRecord

from .physics import WithheldVO2

#: Points of a check run.
CHECK_POINTS = 360


@dataclass(frozen=True)
class RunPlan:
    """One run to make: its record (inputs, measure plan, dwell description) and dwell settings."""

    name: str
    record: ExcitationRecord
    settings: DwellSettings

    @property
    def inputs(self) -> np.ndarray:
        """Set-points (V), shape ``(n,)``."""
        return np.asarray(self.record.inputs, dtype=float)

    def travel_V(self) -> float:
        """Total input travel of the run (V): from 0 V through every set-point and back to 0 V."""
        v = np.concatenate([[0.0], self.inputs, [0.0]])
        return float(np.abs(np.diff(v)).sum())


def config(sim: dict[str, Any], levels: int, seed: int, noise: bool) -> RigConfig:
    """The rig's configuration for one run: the simulated device with ``sim`` overrides and noise seed."""
    changes = dict(sim)
    if not noise:
        changes["psd_noise_V"] = 0.0
    return default_config(levels=levels, seed=seed, **changes)


def fit_plan(grid: Grid) -> RunPlan:
    """The identification run: damped oscillation + thermal point, fixed dwell."""
    settings = DwellSettings(FixedDwell(FIT_DWELL_S), Transit(0.0), READINGS)
    record = make_record(ExcitationRecord.from_excitation(Excitation.damped(grid, True)), settings)
    return RunPlan("fit", record, settings)


def check_plan(cfg: RigConfig, grid: Grid, seed: int, points: int = CHECK_POINTS) -> RunPlan:
    """The check run, ``rig acquire --sequence check`` seeded with ``seed``."""
    window = cfg.heater.limits().window
    args = {"levels": grid.levels, "v_min": grid.v_min, "v_max": grid.v_max, "points": points, "seed": seed}
    schedule = sequence_dwells("check", window, **args)
    settings = DwellSettings(FixedDwell(float(np.max(schedule))), Transit(0.0), READINGS, tuple(schedule))
    return RunPlan("check", make_record(sequence_record("check", window, **args), settings), settings)


def record_run(cfg: RigConfig, device: WithheldVO2, plan: RunPlan, path: str | Path, notes: str = "") -> Path:
    """Record ``plan`` on ``device`` into the new session ``path`` (as ``rig acquire`` does)."""
    with open_rig(cfg, device=device) as rig:
        outcome = rig_acquire(rig, plan, Path(path), notes)
    if outcome.status.value != "complete":
        raise RuntimeError(f"withheld run {path} ended {outcome.status.value}: {outcome.message}")
    return Path(path)


def rig_acquire(rig: Any, plan: RunPlan, path: Path, notes: str) -> Any:
    return acquire(rig, plan.record, path, settings=plan.settings, fsync_interval_s=None,
                   operator="withheld benchmark", notes=notes)


class _Outputs:
    """An in-memory :class:`~rig.acquisition.engine.Recorder`: keeps the recorded deflections."""

    def __init__(self) -> None:
        self.outputs: list[float] = []

    def append(self, t_s: float, input: float, output: float = math.nan, **_: Any) -> int:
        self.outputs.append(output)
        return len(self.outputs)

    def log(self, event: str, message: str = "") -> None:
        pass


def noise_free_outputs(cfg: RigConfig, device: WithheldVO2, plan: RunPlan) -> np.ndarray:
    """The deflections (um, ``(n,)``) ``plan`` records on ``device``, with the sequencer but no file."""
    rec = _Outputs()
    with open_rig(cfg, device=device) as rig:
        seq = Sequencer(rig.heater, rig.sensor, rig.clock, AcquisitionPlan.from_record(plan.record),
                        plan.settings, rec)
        seq.saturate()
        seq.run()
    return np.asarray(rec.outputs, dtype=float)

