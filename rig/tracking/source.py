"""The model ``rig invert`` and ``rig track`` invert, and the checks before anything is applied.

SOURCE is either a session holding the model (``--model NAME``, as ``rig
validate`` names it; default the most recently stored) or a model JSON
file (as ``rig predict`` takes).  Before a voltage is computed, let alone
applied, the model must

* map heater volts to micrometres of deflection (the target file's and
  the rig's units);
* cover the heater's window with its grid (``rig track``): outside the grid
  the model says nothing about the actuator;
* be invertible exactly (:class:`identify.inverse.NotInvertible` names why not);
* reach every target's value somewhere: a target outside the model's output
  range (its major loop's extremes) can never be reached.

Each failure is one line, exit code 2.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from identify import IdentifyError, PreisachModel
from sessions import ModelRecord, read_session
from sessions.formats import FileKind, detect
from sessions.targets import Targets

from ..errors import UserError

#: The units a target file and the rig use.
INPUT_UNIT, OUTPUT_UNIT = "V", "um"
#: Targets beyond the output range by more than this fraction of it are refused.
RANGE_SLACK = 1e-9


@dataclass(frozen=True)
class ModelSource:
    """A model to invert and where it came from: ``record`` (name, method, model), ``path``, ``kind``
    (``session`` or ``json``)."""

    record: ModelRecord
    path: Path
    kind: str

    @property
    def model(self) -> PreisachModel:
        return self.record.model

    def describe(self) -> str:
        where = f"model {self.record.name!r} of {self.path}" if self.kind == "session" else str(self.path)
        effects = [e.name for e in self.model.effects]
        return f"{where} ({self.record.method}, L={self.model.grid.levels}" + (
            f", with {', '.join(effects)})" if effects else ")")


def load_source(path: Path, name: str | None) -> ModelSource:
    """The model in ``path``: a session (``name`` as ``rig validate`` takes it) or a model JSON file."""
    from ..model_file import load_model
    from ..session_input import choose_model

    path = Path(path)
    if path.is_file() and detect(path) is FileKind.HDF5:
        session = read_session(path)
        return ModelSource(choose_model(session, name), path, "session")
    if name is not None:
        raise UserError(f"{path}: --model names a model stored in a session, and this is not a session (a model "
                        "JSON file holds one model)")
    model = load_model(path)
    method = str(model.metadata.get("method", "unknown")) if model.metadata else "unknown"
    fit_rmse = json.loads(path.read_text(encoding="utf-8")).get("rmse_um")  # rig identify --json writes it
    record = ModelRecord(name="model", method=method, model=model, rows=np.zeros(0, np.int64),
                         thermal_term=model.c_d != 0.0,
                         metrics={"rmse": float(fit_rmse)} if isinstance(fit_rmse, (int, float)) else {})
    return ModelSource(record, path, "json")


def check_units(source: ModelSource) -> None:
    """The model must map V to um (a target file's units, the rig's)."""
    m = source.model
    if (m.input_unit, m.output_unit) != (INPUT_UNIT, OUTPUT_UNIT):
        raise UserError(f"{source.path}: the model maps {m.input_unit} to {m.output_unit}, but targets are deflections "
                        f"in {OUTPUT_UNIT} reached by a heater voltage in {INPUT_UNIT}")


def check_window(source: ModelSource, lo: float, hi: float) -> None:
    """The model's grid must cover the heater's window ``[lo, hi]`` (V)."""
    g = source.model.grid
    slack = 1e-9 * (g.v_max - g.v_min)
    if lo < g.v_min - slack or hi > g.v_max + slack:
        raise UserError(f"{source.path}: the model's grid covers [{g.v_min:g}, {g.v_max:g}] V but the heater's window "
                        f"is [{lo:g}, {hi:g}] V; the model says nothing about the actuator outside its grid "
                        "(identify it on a grid spanning the window)")


def check_targets(source: ModelSource, targets: Targets, domain: tuple[float, float], path: Path) -> tuple[float, float]:
    """Refuse targets (read from ``path``) outside the model's output range on ``domain`` (V), naming the
    file line of the first; returns the range (um)."""
    from identify.inverse import output_range

    try:
        lo, hi = output_range(source.model, domain)
    except IdentifyError as exc:
        raise UserError(f"{source.path}: {exc}") from None
    slack = RANGE_SLACK * max(hi - lo, 1e-300)
    y = targets.target_um
    bad = np.flatnonzero((y < lo - slack) | (y > hi + slack))
    if bad.size:
        k = int(bad[0])
        raise UserError(f"{path}: the target on {targets.where(k)} ({y[k]:.6g} um) is outside the model's output range "
                        f"[{lo:.6g}, {hi:.6g}] um on [{domain[0]:g}, {domain[1]:g}] V ({bad.size} target(s) in all): "
                        "no voltage can reach it")
    return lo, hi
