"""Writing a session while it is acquired: one sample at a time, each on disk at once.

:class:`SessionWriter` creates the file with its whole layout, then switches
HDF5 to single-writer/multiple-reader (SWMR) mode: from then on it only
grows ``/samples`` and ``/log``, which SWMR allows, and other processes can
follow the file (:class:`~sessions.reader.SessionFollower`).

Crash safety.  :meth:`SessionWriter.append` grows the table, writes the row
and flushes it (``H5Dflush``) before it returns, and SWMR orders the
metadata writes so that the file on disk is consistent after every step.
Once ``append`` has returned, the sample survives the process being killed
(SIGKILL included): the operating system holds the written pages.  A power
failure is a different matter: the writer also calls ``fsync`` at most every
``fsync_interval_s`` seconds (and on close), so at most that much is at risk
then, but HDF5 does not promise that a file cut by a power failure between
two syncs is readable.

A session whose writer died keeps status ``running`` and the "open for
writing" mark of HDF5; it reads fine, and :meth:`SessionWriter.reopen`
continues it in a fresh copy (see :mod:`sessions.rewrite`).

Storage faults.  A write that fails (disk full, I/O error) or a session file
removed or replaced underneath the writer raises :class:`StorageError`
naming the cause; the row in flight is not counted.  The writer holds a
small :class:`~sessions.storage.Reserve` beside the file and frees it at
the first failure, so that on a full disk the final status is still logged
(once) and the file closed properly; when even that fails the file is
abandoned without crashing (:func:`~sessions.storage.abandon`) and keeps
everything flushed before the fault.  A session removed during the run is
written back to its path from the still-open file when the writer closes.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from interrupts import delay_keyboard_interrupt

from .checksums import create_checked, read_appended
from .errors import DataFileError, StorageError
from .lock import WriterLock
from .log import append_event
from .models import ModelRecord, write_model_group
from .reader import sample_columns
from .records import CalibrationRecord, ExcitationRecord, IdentifyRecipe, Quantities
from .rewrite import rewrite_session
from .storage import Reserve, abandon, check_free_space, storage_reason
from .schema import (
    EVENT_DTYPE,
    FORMAT_NAME,
    LIBVER,
    CALIBRATION_DTYPE,
    SAMPLE_CHUNK,
    SAMPLE_DTYPE,
    SCHEMA_VERSION,
    SampleFlag,
    Status,
    samples_dtype,
    samples_fill,
    software_version,
)


def _json(obj: Any) -> str:
    return json.dumps(obj if obj is not None else {}, sort_keys=True, default=str)


def write_layout(
    f: h5py.File,
    excitation: ExcitationRecord,
    quantities: Quantities,
    operator: str,
    notes: str,
    rig_config: dict[str, Any] | None,
    driver: dict[str, Any] | None,
    calibration: CalibrationRecord | None = None,
    sample_columns: np.dtype | None = None,
    models: tuple[ModelRecord, ...] = (),
    recipe: IdentifyRecipe | None = None,
) -> None:
    """Everything of a new session but its samples and events (see ``docs/sessions.md``).

    ``sample_columns``: extra ``/samples`` columns (a tracking run's, :data:`~sessions.schema.TRACKING_COLUMNS`);
    ``models``: models stored from the start (the model a tracking run inverts); ``recipe``: how the
    session wants to be identified (the root attribute ``identify_recipe``; None: none is written)."""
    a = f.attrs
    a["format"] = FORMAT_NAME
    a["schema_version"] = SCHEMA_VERSION
    a["software_version"] = software_version()
    a["started_at"] = datetime.now(timezone.utc).isoformat(timespec="microseconds")
    a["operator"] = str(operator)
    a["notes"] = str(notes)
    a["rig_config"] = _json(rig_config)
    a["driver"] = _json(driver)
    for key, value in quantities.to_attrs().items():
        a[key] = value
    if recipe is not None:  # an attribute: written now, before SWMR mode allows only growing datasets
        a["identify_recipe"] = _json(recipe.to_dict())
    g = f.create_group("excitation")
    g.attrs["kind"] = excitation.kind
    g.attrs["thermal_term"] = bool(excitation.thermal_term)
    if excitation.levels is not None:
        g.attrs["levels"] = excitation.levels
        g.attrs["v_min"] = excitation.v_min
        g.attrs["v_max"] = excitation.v_max
    if excitation.seed is not None:
        g.attrs["seed"] = int(excitation.seed)
    g.attrs["dwell"] = _json(excitation.dwell)
    g.attrs["extra"] = _json(excitation.extra)
    create_checked(g, "inputs", excitation.inputs)
    create_checked(g, "measure", excitation.measure)
    if excitation.curves is not None:
        create_checked(g, "curve", excitation.curves.astype(np.int32))
    if excitation.targets is not None:
        create_checked(g, "target", excitation.targets)
    if calibration is not None:
        write_calibration(f, calibration)
    if models:
        group = f.create_group("models")
        for record in models:
            write_model_group(group, record)
    create_samples_table(f, samples_dtype(sample_columns))
    f.create_dataset("log", shape=(0,), maxshape=(None,), dtype=EVENT_DTYPE, chunks=(16,))


def create_samples_table(f: h5py.File, dtype: np.dtype) -> h5py.Dataset:
    """An empty ``/samples`` of row type ``dtype``: grown by appends, chunked, each chunk checksummed."""
    return f.create_dataset(
        "samples", shape=(0,), maxshape=(None,), dtype=dtype, chunks=(SAMPLE_CHUNK,),
        fillvalue=samples_fill(dtype), fletcher32=True,
    )


def write_calibration(f: h5py.File, calibration: CalibrationRecord) -> None:
    """The ``/calibration`` table (resizable, so that a live writer could grow it too)."""
    rows = np.zeros(len(calibration), CALIBRATION_DTYPE)
    for name in CALIBRATION_DTYPE.names:
        rows[name] = getattr(calibration, name)
    d = f.create_dataset(
        "calibration", data=rows, maxshape=(None,), chunks=(max(1, min(len(rows), 1024)),), fletcher32=True
    )
    if calibration.drift_correction is not None:
        d.attrs["drift_correction"] = _json(calibration.drift_correction)


class SessionWriter:
    """The single writer of a session file.  Make one with :meth:`create` or :meth:`reopen`.

    Used as a context manager, an exception marks the session ``failed``
    (``aborted`` for Ctrl-C) and a normal exit marks it ``complete`` unless
    :meth:`finish` was called; in every case the file is closed with every
    appended sample kept.
    """

    def __init__(self, path: Path, f: h5py.File, lock: WriterLock, fsync_interval_s: float | None,
                 reserve: Reserve | None = None) -> None:
        self.path = path
        self._file = f
        self._lock = lock
        self._reserve = reserve
        self._samples = f["samples"]
        self._log = f["log"]
        self._count = int(self._samples.shape[0])
        self._planned = int(f["excitation/inputs"].shape[0])
        self._row = np.zeros(1, self._samples.dtype)
        self._fill = samples_fill(self._samples.dtype)
        #: The extra ``/samples`` columns of this session (a tracking run's), in order.
        self.extra_columns = tuple(n for n in self._samples.dtype.names if n not in SAMPLE_DTYPE.names)
        self._status = Status.RUNNING
        self._fsync_interval = fsync_interval_s
        self._fd = f.id.get_vfd_handle()
        self._last_sync = time.monotonic()
        #: The storage fault that stopped this writer (None: healthy).
        self.fault: StorageError | None = None
        self._removed = False
        self._finished = False
        #: Where a session removed during the run was written back to (None: it was not removed).
        self.recovered_to: Path | None = None
        with self._storage_errors("switching to single-writer/multiple-reader mode"):
            f.swmr_mode = True  # from here on: only grow /samples and /log

    # ------------------------------------------------------------ opening
    @classmethod
    def create(
        cls,
        path: str | os.PathLike,
        excitation: ExcitationRecord,
        *,
        quantities: Quantities | None = None,
        operator: str = "",
        notes: str = "",
        rig_config: dict[str, Any] | None = None,
        driver: dict[str, Any] | None = None,
        calibration: CalibrationRecord | None = None,
        fsync_interval_s: float | None = 1.0,
        sample_columns: np.dtype | None = None,
        models: tuple[ModelRecord, ...] = (),
        recipe: IdentifyRecipe | None = None,
    ) -> "SessionWriter":
        """Create a new session at ``path`` (never overwrites) with status ``running``.

        ``rig_config`` and ``driver`` are stored as JSON; ``calibration``
        (drift-monitor points, e.g. of an imported FORC file) as ``/calibration``; ``fsync_interval_s``
        bounds how often the file is synced to disk (0: after every sample,
        ``None``: only on close); ``sample_columns`` adds columns to ``/samples``
        (:meth:`append`'s ``extra``) and ``models`` stores models from the start; ``recipe`` records how
        the session wants to be identified (``rig identify``'s defaults for it; None: none is recorded).
        """
        path = Path(path)
        if path.exists():
            raise DataFileError(f"{path}: already exists; a session is never overwritten")
        try:
            check_free_space(path, excitation.n_points)
        except OSError as exc:
            raise StorageError(f"{path}: cannot create the session ({storage_reason(exc)}); nothing was "
                               "recorded") from None
        try:
            f = h5py.File(path, "w-", libver=LIBVER)
        except FileExistsError:
            raise DataFileError(f"{path}: already exists; a session is never overwritten") from None
        except OSError as exc:
            if path.exists():
                raise DataFileError(f"{path}: already exists; a session is never overwritten") from None
            raise DataFileError(f"{path}: cannot create the session ({exc})") from None
        try:
            lock = WriterLock(path).acquire()
        except BaseException:
            abandon(f.id.get_vfd_handle(), f.close)
            path.unlink(missing_ok=True)
            raise
        reserve = Reserve(path)
        try:
            try:
                reserve.take()
                write_layout(f, excitation, quantities or Quantities(), operator, notes, rig_config, driver,
                             calibration, sample_columns, tuple(models), recipe)
            except (OSError, RuntimeError) as exc:
                raise StorageError(f"{path}: cannot create the session ({storage_reason(exc)}); nothing was "
                                   "recorded") from None
            writer = cls(path, f, lock, fsync_interval_s, reserve)
            writer.log("created", f"{excitation.kind} excitation of {excitation.n_points} points")
        except BaseException:
            abandon(f.id.get_vfd_handle(), f.close)
            lock.release()
            reserve.free()
            path.unlink(missing_ok=True)
            raise
        return writer

    @classmethod
    def reopen(
        cls, path: str | os.PathLike, *, reason: str = "", fsync_interval_s: float | None = 1.0
    ) -> "SessionWriter":
        """Continue an interrupted session (status running with a dead writer, aborted or failed).

        The file is first rewritten into a fresh copy (HDF5 will not reopen a
        file marked "open for writing" by a dead writer); any half-written
        row is dropped.  Appending continues at the next point; the log gets
        a ``reopened`` event with status ``running``.
        """
        path = Path(path)

        def check(session) -> None:
            if session.status is Status.COMPLETE:
                raise DataFileError(f"{path}: the session is complete; there is nothing to resume")
            if session.n_samples >= session.excitation.n_points:
                raise DataFileError(f"{path}: every planned point is already recorded")

        cut_append = False

        def trim(dst: h5py.File, session) -> None:
            nonlocal cut_append
            cut_append = session.cut_append
            if not cut_append:
                dst["samples"].resize((session.n_samples,))
                return
            # the writer died inside an append: the copy's last chunk still fails its checksum, so its rows
            # (whole, sessions.checksums) go into a fresh table whose checksums hold again
            rows, _ = read_appended(dst["samples"], cut_append=True)
            del dst["samples"]
            table = create_samples_table(dst, rows.dtype)
            table.resize((session.n_samples,))
            table[:] = rows[: session.n_samples]

        reserve = Reserve(path)
        try:  # the room to finish a run, and then for a copy of the session, before anything is touched
            check_free_space(path, 0, reserve.size + (path.stat().st_size if path.exists() else 0))
            reserve.take()
        except OSError as exc:
            reserve.free()
            raise StorageError(f"{path}: cannot reopen the session for writing ({storage_reason(exc)}); "
                               "it was not modified") from None
        try:
            lock = rewrite_session(path, trim, check=check, keep_lock=True)
        except BaseException:
            reserve.free()
            raise
        f = None
        try:
            try:
                f = h5py.File(path, "r+", libver=LIBVER)
            except (OSError, RuntimeError) as exc:
                raise StorageError(f"{path}: cannot reopen the session for writing ({storage_reason(exc)})") from None
            writer = cls(path, f, lock, fsync_interval_s, reserve)
        except BaseException:
            if f is not None:
                abandon(f.id.get_vfd_handle(), f.close)
            lock.release()
            reserve.free()
            raise
        cut = " (the last samples chunk was cut by the writer's death; its rows were kept)" if cut_append else ""
        writer.log("reopened", (reason or f"continuing at point {writer.count}") + cut)
        return writer

    # ------------------------------------------------------------ writing
    @property
    def count(self) -> int:
        """Samples in the file: the index the next :meth:`append` gets."""
        return self._count

    @property
    def status(self) -> Status:
        return self._status

    @property
    def closed(self) -> bool:
        return self._lock is None

    def append(
        self,
        t_s: float,
        input: float,
        output: float = np.nan,
        *,
        raw: float = np.nan,
        dwell_s: float = np.nan,
        settled: bool = False,
        measured: bool = True,
        flags: int | SampleFlag = 0,
        extra: dict[str, float] | None = None,
    ) -> int:
        """Record the next applied point and flush it; returns its index.

        Units: ``t_s`` and ``dwell_s`` in s, ``input``/``output``/``raw`` in
        the session's units.  ``output`` is stored as NaN when not
        ``measured``.  ``extra`` gives the session's extra columns by name
        (those not given keep their fill value).  Once this returns, the
        sample is in the file.
        """
        self._require_open()
        k = self._count
        if k >= self._planned:
            raise DataFileError(f"{self.path}: all {self._planned} planned points are already recorded")
        r = self._row
        r["index"] = k
        r["t_s"] = t_s
        r["input"] = input
        r["output"] = output if measured else np.nan
        r["raw"] = raw
        r["dwell_s"] = dwell_s
        r["settled"] = settled
        r["measured"] = measured
        r["flags"] = int(flags)
        for name in self.extra_columns:
            r[name] = self._fill[name]
        if extra:
            unknown = set(extra) - set(self.extra_columns)
            if unknown:
                raise DataFileError(f"{self.path}: the session has no sample column(s) {', '.join(sorted(unknown))}")
            for name, value in extra.items():
                r[name] = value
        with self._storage_errors(f"recording point {k}", row=k):
            self._check_file()
            with delay_keyboard_interrupt():
                self._samples.resize((k + 1,))
                self._samples[k : k + 1] = r
                self._samples.flush()
                self._count = k + 1
            self._maybe_sync()
        return k

    def extend(self, rows: np.ndarray) -> None:
        """Record several points at once (imports).

        ``rows`` is a structured array with the fields of :data:`SAMPLE_DTYPE`
        (matched by name); its ``index`` column is assigned here.
        """
        self._require_open()
        rows = np.asarray(rows).reshape(-1)
        rows = sample_columns(rows, rows.size)  # by column name, a copy
        k, n = self._count, rows.size
        if k + n > self._planned:
            raise DataFileError(f"{self.path}: {k + n} samples exceed the {self._planned} planned points")
        rows["index"] = np.arange(k, k + n)
        rows["output"] = np.where(rows["measured"], rows["output"], np.nan)
        with self._storage_errors(f"recording points {k}..{k + n - 1}", row=k):
            with delay_keyboard_interrupt():
                self._samples.resize((k + n,))
                self._samples[k : k + n] = rows
                self._samples.flush()
                self._count = k + n
            self._maybe_sync()

    def log(self, event: str, message: str = "", status: Status | None = None) -> None:
        """Append an event to the session log (optionally changing the status)."""
        self._require_open()
        if status is not None:
            self._status = Status(status)
        with self._storage_errors(f"logging '{event}'"):
            with delay_keyboard_interrupt():
                append_event(self._log, self._status, event, message, self._count)
            self._maybe_sync()

    def finish(self, status: Status | str = Status.COMPLETE, message: str = "") -> None:
        """Set the final status (complete, aborted or failed) and close the file.

        The final status is logged once, however often this is called.  After
        a storage fault it is a best effort that never raises: the file is
        closed, or abandoned with what was flushed before the fault.
        """
        status = Status(status)
        if not status.final:
            raise ValueError("finish() needs a final status: complete, aborted or failed")
        if self.closed:
            return
        healthy = self.fault is None
        try:
            if not self._finished:
                self.log(status.value, message, status)
                self._finished = True
            self.close()
        except StorageError:
            self._abandon()
            if healthy:  # the fault happened here: the caller must hear of it
                raise

    def close(self) -> None:
        """Flush, sync and close the file and release the lock (the status is left as is)."""
        if self.closed:
            return
        try:
            with self._storage_errors("closing the file"):
                self._file.flush()
                os.fsync(self._fd)
                self._file.close()
        except StorageError:
            try:  # the reserve is free now: room for HDF5 to finish closing
                self._file.close()
            except Exception:
                self._abandon()
                raise
        self._release()

    # ------------------------------------------------------------ internals
    def _require_open(self) -> None:
        if self.closed:
            raise DataFileError(f"{self.path}: the session writer is closed")

    def _maybe_sync(self) -> None:
        if self._fsync_interval is None:
            return
        now = time.monotonic()
        if now - self._last_sync >= self._fsync_interval:
            os.fsync(self._fd)
            self._last_sync = now

    def _check_file(self) -> None:
        """Raise if the session file was removed, moved or replaced since it was opened."""
        if self._removed or self._lock.still_names_the_file():
            return
        if os.fstat(self._fd).st_nlink == 0:
            self._removed = True
            raise StorageError(f"{self.path}: the session file was removed during the run; recording stopped "
                               "(the samples are written back to it when the run ends)")
        raise StorageError(f"{self.path}: the session file was moved or replaced during the run; recording stopped")

    @contextmanager
    def _storage_errors(self, what: str, row: int | None = None) -> Iterator[None]:
        """Turn a failed write into :class:`StorageError`, once; free the reserve; blank row ``row``."""
        try:
            yield
        except StorageError as exc:
            self._fail(exc, row)
            raise
        except (OSError, RuntimeError) as exc:
            err = StorageError(f"{self.path}: cannot write the session ({storage_reason(exc)}) while {what}; "
                               "every sample recorded before is kept")
            self._fail(err, row)
            raise err from None

    def _fail(self, err: StorageError, row: int | None) -> None:
        if self.fault is None:
            self.fault = err
        if self._reserve is not None:
            self._reserve.free()  # room to log the final status and close
        if row is not None:
            try:  # the row in flight must not reach the file later, when HDF5 flushes its cache
                if self._samples.shape[0] > row:
                    self._samples[row : row + 1] = self._fill
            except Exception:
                pass

    def _release(self) -> None:
        """After the file is closed: write a removed session back, release the lock and the reserve."""
        if self._removed and self._lock is not None:
            self.recovered_to = _write_back(self._lock, self.path)
        if self._lock is not None:
            self._lock.release()
            self._lock = None
        if self._reserve is not None:
            self._reserve.free()

    def _abandon(self) -> None:
        """Close after a failure, keeping whatever reached the file (never crashes, never raises)."""
        if self._lock is None:
            return
        abandon(self._fd, self._file.close)
        self._release()

    def __enter__(self) -> "SessionWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.closed:
            return
        try:
            if exc_type is None:
                if self._status is Status.RUNNING:
                    self.finish(Status.COMPLETE)
                else:
                    self.close()
            elif issubclass(exc_type, KeyboardInterrupt):
                self.finish(Status.ABORTED, "interrupted (Ctrl-C)")
            else:
                self.finish(Status.FAILED, f"{exc_type.__name__}: {exc}")
        except Exception:
            self._abandon()
            if exc_type is None:
                raise  # otherwise the original exception is the one to report



def _write_back(lock: WriterLock, path: Path) -> Path | None:
    """Copy a session file that was removed while open (``lock`` still holds it) back to ``path`` -- or,
    when that name is taken or its directory is gone, to a ``.recovered`` file beside it or in the
    system's temporary directory.  Returns where it went (None: nowhere could take it)."""
    candidates = [path, path.with_name(f"{path.name}.recovered"),
                  Path(tempfile.gettempdir()) / f"{path.name}.recovered-{os.getpid()}"]
    for target in candidates:
        try:
            out = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o644)
        except OSError:
            continue
        try:
            with os.fdopen(os.dup(lock.fd), "rb") as src, os.fdopen(out, "wb") as dst:
                src.seek(0)
                shutil.copyfileobj(src, dst)
                dst.flush()
                os.fsync(dst.fileno())
            return target
        except OSError:
            target.unlink(missing_ok=True)
    return None
