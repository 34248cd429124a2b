"""Identified models stored inside a session, under ``/models/<name>``.

A model group holds what :func:`identify.model_json.model_to_dict` says, split
so that HDF5 tools show it plainly:

* datasets ``walls`` ``(L+1,)`` (input unit), ``density`` ``(L, L)`` (output
  unit; ``density[i, j]`` is cell ``(i, j)``, zero above the diagonal) and
  ``rows`` ``(M,)`` (the sample rows the fit used);
* attributes ``model_format``, ``levels``, ``v_min``, ``v_max``, ``mu0``,
  ``c_d``, ``input_unit``, ``output_unit`` (the rest of the model), and
  ``method``, ``settings`` (JSON), ``metrics`` (JSON: ``rmse``, ``nrmse``,
  ``max_abs``, ``n_measured``, ``n_points``, ``seconds``), ``thermal_term``,
  ``seed`` (absent when the rows were not chosen at random),
  ``created_at`` (ISO 8601, UTC) and ``software_version``; ``effects``
  (JSON: ``[{"name", "params"}, ...]``, :mod:`identify.effects`) only when
  the model was identified with effects.

Models are added to a finished session by :func:`sessions.rewrite.add_model`,
which never touches the original file until the new one is complete.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

import h5py
import numpy as np

from identify import IdentifyError, PreisachModel
from identify.fit import FitReport
from identify.model_json import model_from_dict, model_to_dict

from .checksums import create_checked, read_checked
from .errors import DataFileError
from .schema import software_version

#: Allowed model names: a letter or digit, then letters, digits, ``_ . + -``.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}")

_MODEL_KEYS = ("levels", "v_min", "v_max", "mu0", "c_d", "input_unit", "output_unit")


def check_model_name(name: str) -> str:
    """``name`` if it is a valid model name, else :class:`DataFileError`."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise DataFileError(
            f"model name {name!r} is not allowed: use 1-64 letters, digits, '_', '.', '+' or '-', "
            "starting with a letter or digit"
        )
    return name


def utc_now() -> str:
    """The current time as ISO 8601 in UTC, to the microsecond."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


@dataclass(frozen=True, eq=False)
class ModelRecord:
    """A model identified from a session, with how it was obtained."""

    name: str
    method: str
    model: PreisachModel
    rows: np.ndarray
    thermal_term: bool
    seed: int | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    metrics: dict[str, Any] = field(default_factory=dict)
    created_at: str = field(default_factory=utc_now)
    software_version: str = field(default_factory=software_version)

    def __post_init__(self) -> None:
        check_model_name(self.name)
        object.__setattr__(self, "rows", np.asarray(self.rows, dtype=np.int64).reshape(-1))

    @classmethod
    def from_report(
        cls, name: str, report: FitReport, thermal_term: bool, seed: int | None, model: PreisachModel | None = None
    ) -> "ModelRecord":
        """The record of a fit (``model`` overrides ``report.model``, e.g. to set units)."""
        return cls(
            name=name,
            method=report.method,
            model=report.model if model is None else model,
            rows=report.rows,
            thermal_term=thermal_term,
            seed=seed,
            settings=dict(report.settings),
            metrics={
                "rmse": report.rmse,
                "nrmse": report.nrmse,
                "max_abs": report.max_abs,
                "n_measured": report.n_measured,
                "n_points": report.n_points,
                "seconds": report.seconds,
            },
        )


def _json(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, default=str)


def write_model_group(parent: h5py.Group, record: ModelRecord) -> h5py.Group:
    """Create ``parent/<name>`` holding ``record`` (the name must be free)."""
    d = model_to_dict(record.model)
    g = parent.create_group(record.name)
    create_checked(g, "walls", np.asarray(d["walls"], dtype=float))
    create_checked(g, "density", np.asarray(d["density"], dtype=float))
    create_checked(g, "rows", record.rows)
    g.attrs["model_format"] = d["format"]
    for key in _MODEL_KEYS:
        g.attrs[key] = d[key]
    if "metadata" in d:
        g.attrs["metadata"] = _json(d["metadata"])
    if "effects" in d:
        g.attrs["effects"] = _json(d["effects"])
    g.attrs["method"] = record.method
    g.attrs["thermal_term"] = bool(record.thermal_term)
    if record.seed is not None:
        g.attrs["seed"] = int(record.seed)
    g.attrs["settings"] = _json(record.settings)
    g.attrs["metrics"] = _json(record.metrics)
    g.attrs["created_at"] = record.created_at
    g.attrs["software_version"] = record.software_version
    return g


def read_model_group(group: h5py.Group) -> ModelRecord:
    """The :class:`ModelRecord` in ``group``; :class:`DataFileError` if malformed."""
    name = group.name.rsplit("/", 1)[-1]
    a = group.attrs
    try:
        data = {key: a[key] for key in _MODEL_KEYS}
        data["format"] = int(a["model_format"])
        data["walls"] = read_checked(group["walls"])
        data["density"] = read_checked(group["density"])
        if "metadata" in a:
            data["metadata"] = json.loads(a["metadata"])
        if "effects" in a:
            data["effects"] = json.loads(a["effects"])
        data = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in data.items()}
        model = model_from_dict(data)
        return ModelRecord(
            name=name,
            method=str(a["method"]),
            model=model,
            rows=read_checked(group["rows"]),
            thermal_term=bool(a["thermal_term"]),
            seed=int(a["seed"]) if "seed" in a else None,
            settings=json.loads(a["settings"]),
            metrics=json.loads(a["metrics"]),
            created_at=str(a["created_at"]),
            software_version=str(a["software_version"]),
        )
    except DataFileError:
        raise
    except KeyError as exc:
        raise DataFileError(f"model {name!r} is incomplete: missing {exc.args[0]!r}") from None
    except (IdentifyError, ValueError, TypeError) as exc:
        raise DataFileError(f"model {name!r} is malformed: {exc}") from None
