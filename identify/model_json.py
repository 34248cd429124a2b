"""A model's JSON form: what model files, ``rig identify --json`` and sessions store.

:func:`model_to_dict` writes a :class:`~identify.model.PreisachModel` as a
JSON-safe dictionary -- the grid (levels, range, walls), ``mu0`` (um),
``c_d`` (um/V), the density as an ``(L, L)`` list of lists (zero above the
diagonal), the units, the metadata and the fitted effects
(``[{"name", "params"}]``, :func:`identify.effects.effect_to_dict`) -- and
:func:`model_from_dict` reads it back exactly, refusing with a one-line
:class:`~identify.errors.IdentifyError` whatever a hand edit may have
broken.  A model without effects writes exactly what it wrote before
effects existed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .effects import effect_from_dict, effect_to_dict, pipeline_order
from .errors import IdentifyError
from .grid import Grid
from .model import PreisachModel

#: Version of the JSON-safe dictionary written by :func:`model_to_dict`.
MODEL_FORMAT = 1


def model_to_dict(model: PreisachModel) -> dict[str, Any]:
    """The JSON-safe dictionary of ``model`` (read back by :func:`model_from_dict`)."""
    return {
        "format": MODEL_FORMAT,
        "levels": model.grid.levels,
        "v_min": model.grid.v_min,
        "v_max": model.grid.v_max,
        "walls": [float(x) for x in model.grid.walls],
        "mu0": model.mu0,
        "c_d": model.c_d,
        "density": model.density_matrix().tolist(),
        "input_unit": model.input_unit,
        "output_unit": model.output_unit,
        **({"metadata": model.metadata} if model.metadata else {}),
        **({"effects": [effect_to_dict(e) for e in model.effects]} if model.effects else {}),
    }


def model_from_dict(data: Any) -> PreisachModel:
    """Read a model written by :func:`model_to_dict` (or ``rig identify --json``)."""
    if not isinstance(data, dict):
        raise IdentifyError("model must be a JSON object")
    missing = [k for k in ("walls", "mu0", "c_d", "density") if k not in data]
    if missing:
        raise IdentifyError(f"model is missing the key(s) {', '.join(missing)}")
    fmt = data.get("format", MODEL_FORMAT)
    if not isinstance(fmt, int) or fmt > MODEL_FORMAT:
        raise IdentifyError(f"model format {fmt!r} is newer than this program understands")
    try:
        walls = np.asarray(data["walls"], dtype=float)
        density = np.asarray(data["density"], dtype=float)
        mu0, c_d = float(data["mu0"]), float(data["c_d"])
    except (TypeError, ValueError) as exc:
        raise IdentifyError(f"model has a non-numeric value: {exc}") from None
    if walls.ndim != 1 or walls.size < 2 or not np.all(np.isfinite(walls)):
        raise IdentifyError("model 'walls' must be a list of at least 2 finite numbers")
    levels = walls.size - 1
    if "levels" in data and data["levels"] != levels:
        raise IdentifyError(f"model says levels={data['levels']!r} but has {walls.size} walls")
    grid = Grid(levels, walls[0], walls[-1])
    if not np.allclose(walls, grid.walls, rtol=0, atol=1e-9 * (grid.v_max - grid.v_min)):
        raise IdentifyError("model walls are not uniformly spaced")
    for key, wall in (("v_min", walls[0]), ("v_max", walls[-1])):
        said = data.get(key)
        if said is not None and not (isinstance(said, (int, float)) and abs(said - wall) <= 1e-9 * abs(walls[-1] - walls[0])):
            raise IdentifyError(f"model says {key}={said!r} but its walls {'start' if key == 'v_min' else 'end'} at "
                                f"{wall:g}: the model contradicts itself (edited by hand?)")
    if density.shape != (levels, levels):
        raise IdentifyError(f"model 'density' must be a {levels}x{levels} list of lists, got shape {density.shape}")
    if not np.all(np.isfinite(density)):
        raise IdentifyError("model 'density' has non-finite values")
    effects = data.get("effects", [])
    if not isinstance(effects, list):
        raise IdentifyError("model 'effects' must be a list of {\"name\", \"params\"} objects")
    if effects:
        effects = pipeline_order(effect_from_dict(e) for e in effects)
    return PreisachModel(
        grid,
        grid.density_vector(density),
        mu0,
        c_d,
        input_unit=str(data.get("input_unit", "V")),
        output_unit=str(data.get("output_unit", "um")),
        metadata=dict(data.get("metadata", {})),
        effects=tuple(effects),
    )
