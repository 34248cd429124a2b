"""Reading sessions: a validated snapshot, or following a session being written.

Files are only ever opened read-only: normally, so that HDF5's full checks
apply, or in SWMR-read mode when the file is marked "open for writing"
(its writer is running or died), the only way HDF5 opens such a file.
Anything that is not a readable session of a schema version this program
understands raises :class:`DataFileError` naming the problem.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from identify import Grid

from .checksums import read_appended, read_checked
from .errors import DataFileError
from .lock import held_by_other
from .models import ModelRecord, read_model_group
from .records import CalibrationRecord, Event, ExcitationRecord, IdentifyRecipe, Quantities
from .schema import ADAPTIVE_KIND, CALIBRATION_DTYPE, EVENT_DTYPE, FORMAT_NAME, SAMPLE_DTYPE, SCHEMA_VERSION, Status
from .swmr import open_swmr_read


@dataclass(frozen=True, eq=False)
class Session:
    """Everything in a session file, as read at one moment.

    ``samples`` is a structured array of :data:`~sessions.schema.SAMPLE_DTYPE`
    with one row per applied point written so far (row ``k`` is point ``k``
    of ``excitation``).
    """

    path: Path
    schema_version: int
    software_version: str
    started_at: str
    operator: str
    notes: str
    rig_config: dict[str, Any]
    driver: dict[str, Any]
    quantities: Quantities
    excitation: ExcitationRecord
    samples: np.ndarray
    events: tuple[Event, ...]
    models: dict[str, ModelRecord]
    calibration: CalibrationRecord | None = None
    #: The extra ``/samples`` columns a producer added (a tracking run's ``target``, ``predicted``, ...), one
    #: row per sample; None when the session has none.
    extra: np.ndarray | None = None
    #: How the session wants to be identified (root attribute ``identify_recipe``), written by ``rig acquire``;
    #: None for a session that records none (every session written before it existed, imports, tracking runs).
    recipe: IdentifyRecipe | None = None
    #: Whether the last chunk of ``/samples`` fails its checksum because its writer died while appending to
    #: it (a session still ``running``): its rows up to the table's length were read unverified, which is
    #: safe for a cut append (:mod:`sessions.checksums`).  Resuming writes them back checked.
    cut_append: bool = False

    # ------------------------------------------------------------ status
    @property
    def status(self) -> Status:
        """The status set by the last event of the log."""
        return self.events[-1].status

    @property
    def ended_at(self) -> str | None:
        """When the session reached its final status (ISO 8601, UTC), or ``None``."""
        if not self.status.final:
            return None
        k = len(self.events) - 1
        while k > 0 and self.events[k - 1].status is self.status:  # later events (a stored model) keep it
            k -= 1
        return datetime.fromtimestamp(self.events[k].t_unix, timezone.utc).isoformat(timespec="microseconds")

    @property
    def is_partial(self) -> bool:
        """Not complete, or fewer samples than planned points (except a run that decides its own length,
        excitation kind ``adaptive``, whose plan is its most points)."""
        if self.status is not Status.COMPLETE:
            return True
        return self.n_samples < self.excitation.n_points and self.excitation.kind != ADAPTIVE_KIND

    def writer_alive(self) -> bool:
        """Whether a process is writing this session now (it holds the writer's lock)."""
        return held_by_other(self.path)

    # ------------------------------------------------------------ columns
    @property
    def n_samples(self) -> int:
        return int(self.samples.size)

    @property
    def t_s(self) -> np.ndarray:
        return self.samples["t_s"]

    @property
    def inputs(self) -> np.ndarray:
        """Every applied input, ``(n,)``: the history that sets each row's memory state."""
        return self.samples["input"]

    @property
    def measured(self) -> np.ndarray:
        return self.samples["measured"]

    @property
    def outputs(self) -> np.ndarray:
        """Outputs ``(n,)``, NaN where the point was applied but not measured -- or, in a run to a target that
        found its own dwell, measured at a dwell a longer one superseded (:attr:`superseded`)."""
        return np.where(self.measured & ~self.superseded, self.samples["output"], np.nan)

    @property
    def superseded(self) -> np.ndarray:
        """Which points ``(n,)`` bool were measured before the run found they were not at rest: in a run to
        a target that finds its own dwell (``first_dwell_s`` in the excitation's ``extra``), those whose
        asked wait (``asked_dwell_s``; a pause lengthens the recorded ``dwell_s``, not this) is shorter than
        the run's final dwell (:func:`identify.settling.superseded`); they set the memory state but are no
        quasi-static reading.  None elsewhere."""
        found = self._found_dwell()
        if found is None:
            return np.zeros(self.n_samples, bool)
        from identify.settling import superseded

        return superseded(*found)

    @property
    def final_dwell_s(self) -> float | None:
        """The dwell (s) a run to a target that finds its own dwell ended at; None for other sessions."""
        found = self._found_dwell()
        if found is None:
            return None
        from identify.settling import final_dwell

        return final_dwell(*found)

    def _found_dwell(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(waits, kinds)`` ``(n,)`` of a run to a target that finds its own dwell: the wait asked of each
        point (s; older sessions: the recorded ``dwell_s``) and its ``point_kind``; None for other sessions."""
        n = self.n_samples
        names = () if self.extra is None else (self.extra.dtype.names or ())
        if "first_dwell_s" not in self.excitation.extra or "point_kind" not in names:
            return None
        waits = self.extra["asked_dwell_s"][:n] if "asked_dwell_s" in names else self.samples["dwell_s"]
        return waits, self.extra["point_kind"][:n]

    @property
    def measured_rows(self) -> np.ndarray:
        return np.flatnonzero(self.measured)

    @property
    def grid(self) -> Grid | None:
        """The excitation's grid, if recorded."""
        return self.excitation.grid

    @property
    def curves(self) -> np.ndarray | None:
        """The curve of every recorded sample ``(n,)`` (-1: none), or ``None`` without curves."""
        c = self.excitation.curves
        return None if c is None else c[: self.n_samples]

    @property
    def drift_correction(self) -> dict[str, Any] | None:
        """How the outputs were corrected for drift (``None``: as measured)."""
        return None if self.calibration is None else self.calibration.drift_correction


# ---------------------------------------------------------------- helpers
def _hdf5_message(exc: BaseException) -> str:
    """An HDF5 error message on one line, without HDF5's API jargon."""
    return " ".join(str(exc).replace("synchronously ", "").strip("'\"").split())


def _text(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def _json_attr(attrs: h5py.AttributeManager, key: str) -> Any:
    try:
        return json.loads(_text(attrs[key]))
    except json.JSONDecodeError as exc:
        raise DataFileError(f"attribute {key!r} is not valid JSON ({exc.msg})") from None


def _dataset(parent: h5py.Group, name: str, dtype: np.dtype | None = None) -> h5py.Dataset:
    obj = parent.get(name)
    if not isinstance(obj, h5py.Dataset):
        raise DataFileError(f"missing dataset {parent.name.rstrip('/')}/{name}")
    if dtype is not None:
        missing = [f for f in dtype.names if f not in (obj.dtype.names or ())]
        if missing:
            raise DataFileError(f"{obj.name} lacks the column(s) {', '.join(missing)}")
    return obj


def valid_rows(raw: np.ndarray) -> int:
    """How many leading rows of ``/samples`` were written (row ``k`` has index ``k``).

    Rows after them may only hold the fill value (index -1): a writer that
    died between growing the table and writing the row leaves one.
    """
    ok = raw["index"] == np.arange(raw.size)
    n = int(raw.size if ok.all() else np.argmin(ok))
    bad = np.flatnonzero(raw["index"][n:] != -1)
    if bad.size:
        k = n + int(bad[0])
        raise DataFileError(f"/samples row {k} has index {raw['index'][k]}, expected {k}")
    return n


def sample_columns(raw: np.ndarray, n: int) -> np.ndarray:
    """The first ``n`` rows of ``raw`` as :data:`SAMPLE_DTYPE` (extra columns dropped)."""
    out = np.empty(n, SAMPLE_DTYPE)
    for name in SAMPLE_DTYPE.names:
        out[name] = raw[name][:n]
    return out


def extra_columns(raw: np.ndarray, n: int) -> np.ndarray | None:
    """The first ``n`` rows of the columns of ``raw`` beyond :data:`SAMPLE_DTYPE` (None: there are none)."""
    names = [name for name in raw.dtype.names if name not in SAMPLE_DTYPE.names]
    if not names:
        return None
    out = np.empty(n, np.dtype([(name, raw.dtype[name]) for name in names]))
    for name in names:
        out[name] = raw[name][:n]
    return out


def read_events(log: h5py.Dataset) -> tuple[Event, ...]:
    """The events of ``/log``; trailing rows still holding the fill value (no
    status: the writer grew the table but had not written the row) are ignored."""
    rows = log[()]
    n = rows.size
    while n and rows["status"][n - 1] == b"":
        n -= 1
    events = []
    for row in rows[:n]:
        try:
            status = Status(_text(row["status"]))
        except ValueError:
            raise DataFileError(f"/log has an unknown status {_text(row['status'])!r}") from None
        events.append(
            Event(float(row["t_unix"]), int(row["n_samples"]), status, _text(row["event"]), _text(row["message"]))
        )
    if not events:
        raise DataFileError("/log is empty (every session starts with a 'created' event)")
    return tuple(events)


def read_excitation(group: h5py.Group) -> ExcitationRecord:
    a = group.attrs

    def optional(key: str, kind: type) -> Any:
        return kind(a[key]) if key in a else None

    return ExcitationRecord(
        kind=_text(a["kind"]),
        inputs=read_checked(_dataset(group, "inputs")),
        measure=read_checked(_dataset(group, "measure")),
        levels=optional("levels", int),
        v_min=optional("v_min", float),
        v_max=optional("v_max", float),
        thermal_term=bool(a.get("thermal_term", False)),
        seed=optional("seed", int),
        dwell=_json_attr(a, "dwell") if "dwell" in a else {},
        extra=_json_attr(a, "extra") if "extra" in a else {},
        curves=read_checked(_dataset(group, "curve")) if "curve" in group else None,
        targets=read_checked(_dataset(group, "target")) if "target" in group else None,
    )


def read_recipe(attrs: h5py.AttributeManager) -> IdentifyRecipe | None:
    """The root attribute ``identify_recipe``, or ``None`` when the session has none."""
    if "identify_recipe" not in attrs:
        return None
    try:
        return IdentifyRecipe.from_dict(_json_attr(attrs, "identify_recipe"))
    except DataFileError as exc:
        raise DataFileError(f"attribute 'identify_recipe' is malformed: {exc}") from None


def read_calibration(f: h5py.File) -> CalibrationRecord | None:
    """``/calibration``, or ``None`` when the session has none."""
    if "calibration" not in f:
        return None
    d = _dataset(f, "calibration", CALIBRATION_DTYPE)
    rows = read_checked(d)
    drift = _json_attr(d.attrs, "drift_correction") if "drift_correction" in d.attrs else None
    return CalibrationRecord(*(rows[name].copy() for name in CALIBRATION_DTYPE.names), drift_correction=drift)


def open_hdf5(path: str | os.PathLike) -> h5py.File:
    """Open ``path`` read-only, or raise :class:`DataFileError` saying why not.

    A file marked as open for writing (by a live writer or one that died) is
    opened in SWMR-read mode, which HDF5 requires for it; any other file is
    opened normally, so that HDF5's full checks (truncation included) apply.
    """
    path = Path(path)
    if not path.exists():
        raise DataFileError(f"{path}: no such file")
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory, not a session file")
    if path.stat().st_size == 0:
        raise DataFileError(f"{path}: empty file, not a session")
    if not h5py.is_hdf5(path):
        raise DataFileError(f"{path}: not an HDF5 file, so not a session")
    try:
        try:
            return h5py.File(path, "r")
        except OSError as exc:
            if "already open for write" not in str(exc):
                raise
        # marked "open for writing": its writer is running or died; SWMR reads it
        return open_swmr_read(path)
    except (OSError, RuntimeError) as exc:
        why = _hdf5_message(exc)
        if "unable to lock file" in why:
            raise DataFileError(f"{path}: locked by a program that is writing it; try again later") from None
        what = "truncated" if "truncated" in why else "corrupt"
        raise DataFileError(f"{path}: {what} HDF5 file, cannot be read ({why})") from None


def check_header(path: Path, f: h5py.File) -> int:
    """The schema version of an open file, after checking that it is a session."""
    fmt = f.attrs.get("format")
    if fmt is None or _text(fmt) != FORMAT_NAME:
        raise DataFileError(f"{path}: an HDF5 file but not a vo2rig session (no format={FORMAT_NAME!r} attribute)")
    try:
        version = int(f.attrs["schema_version"])
    except (KeyError, TypeError, ValueError):
        raise DataFileError(f"{path}: session without a valid schema_version attribute") from None
    if version > SCHEMA_VERSION:
        raise DataFileError(
            f"{path}: session schema version {version} is newer than this program understands "
            f"(up to {SCHEMA_VERSION}); upgrade vo2rig to read it"
        )
    if version < 1:
        raise DataFileError(f"{path}: invalid session schema version {version}")
    return version


def _read(path: Path, f: h5py.File) -> Session:
    version = check_header(path, f)
    a = f.attrs
    events = read_events(_dataset(f, "log", EVENT_DTYPE))
    raw, cut = read_appended(_dataset(f, "samples", SAMPLE_DTYPE), cut_append=events[-1].status is Status.RUNNING)
    n = valid_rows(raw)
    samples = sample_columns(raw, n)
    excitation = read_excitation(f["excitation"])
    if samples.size > excitation.n_points:
        raise DataFileError(f"{samples.size} samples but the excitation plans only {excitation.n_points} points")
    models = f.get("models", {})
    return Session(
        path=path,
        schema_version=version,
        software_version=_text(a["software_version"]),
        started_at=_text(a["started_at"]),
        operator=_text(a.get("operator", "")),
        notes=_text(a.get("notes", "")),
        rig_config=_json_attr(a, "rig_config"),
        driver=_json_attr(a, "driver"),
        quantities=Quantities(**{k: _text(a[k]) for k in Quantities.__dataclass_fields__}),
        excitation=excitation,
        samples=samples,
        events=events,
        models={name: read_model_group(models[name]) for name in models},
        calibration=read_calibration(f),
        extra=extra_columns(raw, n),
        recipe=read_recipe(a),
        cut_append=cut,
    )


def read_session(path: str | os.PathLike) -> Session:
    """Read and validate a whole session (never modifies the file).

    Works on a session that is being written (you get the samples flushed so
    far) and on one whose writer died.
    """
    path = Path(path)
    with open_hdf5(path) as f:
        try:
            return _read(path, f)
        except DataFileError as exc:
            if str(exc).startswith(f"{path}:"):
                raise
            raise DataFileError(f"{path}: corrupt session: {exc}") from None
        except KeyError as exc:
            raise DataFileError(f"{path}: corrupt session: missing {_hdf5_message(exc)}") from None
        except (OSError, RuntimeError, ValueError, TypeError) as exc:
            raise DataFileError(f"{path}: corrupt session: {_hdf5_message(exc)}") from None


def is_hdf5(path: str | os.PathLike) -> bool:
    """Whether ``path`` is an HDF5 file (so should be read as a session, not a CSV)."""
    try:
        return Path(path).is_file() and h5py.is_hdf5(path)
    except OSError:
        return False


class SessionFollower:
    """Follow a session while another process writes it (live viewing).

    ``poll()`` returns the sample rows flushed since the last call;
    ``samples`` all rows seen so far; ``status`` the current status.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        read_session(self.path)  # validate first, with the clear errors
        self._file = open_swmr_read(self.path)
        self._samples = self._file["samples"]
        self._log = self._file["log"]
        self._parts: list[np.ndarray] = []
        self._n = 0

    def poll(self) -> np.ndarray:
        """New sample rows, shape ``(k,)`` with ``k >= 0``."""
        self._samples.refresh()
        size = self._samples.shape[0]
        if size <= self._n:
            return np.empty(0, SAMPLE_DTYPE)
        # a live writer rewrites the last chunk at every append: a read that meets it half-written
        # still holds every row up to ``size`` whole (sessions.checksums)
        tail, _ = read_appended(self._samples, self._n, cut_append=True)  # rows self._n to size
        ok = tail["index"] == np.arange(self._n, size)
        new = sample_columns(tail, tail.size if ok.all() else int(np.argmin(ok)))
        self._n += new.size
        self._parts.append(new)
        return new

    @property
    def samples(self) -> np.ndarray:
        return np.concatenate(self._parts) if self._parts else np.empty(0, SAMPLE_DTYPE)

    @property
    def events(self) -> tuple[Event, ...]:
        """The session log as flushed so far."""
        self._log.refresh()
        return read_events(self._log)

    @property
    def status(self) -> Status:
        return self.events[-1].status

    def replaced(self) -> bool:
        """Whether the path no longer names the file being followed: a rewrite renamed a new file over
        it (a resumed run, a stored model) or it was removed.  The old file reads on, unchanged."""
        try:
            a, b = os.stat(self.path), os.fstat(self._file.id.get_vfd_handle())
        except OSError:
            return True
        return (a.st_dev, a.st_ino) != (b.st_dev, b.st_ino)

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> "SessionFollower":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
