"""Changing a session that already exists, without ever putting it at risk.

HDF5 keeps no journal: a process killed while it changes a file's metadata
in place (adding a group, say) can leave the whole file unreadable.  So an
existing session is never modified in place.  :func:`rewrite_session`

1. takes the writer's lock (:mod:`sessions.lock`), so a live writer or
   another rewrite cannot race it;
2. copies the session into a hidden file beside it (``.NAME.rewrite``) and
   applies the change to the copy;
3. reads the copy back as a session and checks that it holds the very same
   samples and log as the original;
4. flushes the copy to disk (``fsync``), renames it over the original
   (``os.replace``, atomic on POSIX) and syncs the directory.

Killed at any moment, the path names either the untouched original or the
complete new copy; a leftover ``.NAME.rewrite`` is garbage that the next
rewrite replaces.  A reader holding the old file open keeps reading it.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from .errors import DataFileError, StorageError
from .lock import WriterLock
from .log import append_event
from .models import ModelRecord, write_model_group
from .reader import Session, open_hdf5, read_session
from .schema import LIBVER
from .storage import abandon, storage_reason

#: ``edit(copy, original)``: change the open copy; ``original`` is the session as read.
Edit = Callable[[h5py.File, Session], None]


def rewrite_path(path: Path) -> Path:
    """The hidden temporary file a rewrite of ``path`` works in."""
    return path.with_name(f".{path.name}.rewrite")


def copy_contents(src: h5py.File, dst: h5py.File) -> None:
    """Copy every root attribute (with its HDF5 type) and object of ``src`` into ``dst``."""
    for name in src.attrs:
        dst.attrs.create(name, src.attrs[name], dtype=src.attrs.get_id(name).dtype)
    for name in src:
        src.copy(src[name], dst, name=name)


def fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_directory(path: Path) -> None:
    """Make a rename in ``path`` durable (best effort where directories cannot be synced)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def rewrite_session(
    path: str | os.PathLike,
    edit: Edit,
    *,
    check: Callable[[Session], None] | None = None,
    keep_lock: bool = False,
) -> WriterLock | None:
    """Apply ``edit`` to a copy of the session at ``path`` and atomically replace it.

    ``check(original)`` may raise to refuse the change before anything is
    written.  With ``keep_lock`` the writer's lock on the new file is
    returned, still held (the caller goes on writing it).
    """
    path = Path(path)
    read_session(path)  # clear errors for what is not a session, before locking
    lock = WriterLock(path).acquire()
    tmp = rewrite_path(path)
    new_lock = None
    try:
        if not lock.still_names_the_file():
            raise DataFileError(f"{path}: was replaced by another process meanwhile; try again")
        before = read_session(path)
        if check is not None:
            check(before)
        tmp.unlink(missing_ok=True)
        try:
            _write_copy(path, tmp, lambda dst: edit(dst, before))
            after = read_session(tmp)
            if (
                after.samples.tobytes() != before.samples.tobytes()
                or after.events[: len(before.events)] != before.events
                or _calibration_bytes(after) != _calibration_bytes(before)
            ):
                raise DataFileError(f"{path}: the rewritten copy lost samples or events; the session was not modified")
            fsync_file(tmp)
            if keep_lock:
                new_lock = WriterLock(tmp).acquire()
            os.replace(tmp, path)
        except (OSError, RuntimeError) as exc:
            raise StorageError(f"{path}: could not write a new copy of the session beside it ({storage_reason(exc)}); "
                               "the session was not modified") from None
        fsync_directory(path.parent)
    except BaseException:
        if new_lock is not None:
            new_lock.release()
        tmp.unlink(missing_ok=True)
        raise
    finally:
        lock.release()
    if new_lock is not None:
        new_lock.path = path
    return new_lock


def _write_copy(path: Path, tmp: Path, edit: Callable[[h5py.File], None]) -> None:
    """Copy the session at ``path`` into the new file ``tmp`` and apply ``edit`` to it.  A copy whose
    writes fail (a full disk) is abandoned so that HDF5 cannot crash later re-trying to close it."""
    with open_hdf5(path) as src:
        dst = h5py.File(tmp, "w-", libver=LIBVER)
        try:
            copy_contents(src, dst)
            edit(dst)
            dst.close()
        except BaseException:
            abandon(dst.id.get_vfd_handle() if dst.id.valid else None, dst.close)
            raise
    shutil.copymode(path, tmp)


def _calibration_bytes(session: Session) -> bytes | None:
    c = session.calibration
    return None if c is None else b"".join(np.asarray(getattr(c, k)).tobytes() for k in ("t_s", "input", "output"))


def add_model(path: str | os.PathLike, record: ModelRecord, *, force: bool = False) -> None:
    """Store ``record`` under ``/models/<name>`` of a finished session.

    Refuses a session that is still running (or whose writer died: resume
    or close it first) and an existing name unless ``force``.  The log gets
    a ``model`` event.
    """
    path = Path(path)

    def check(session: Session) -> None:
        if not session.status.final:
            raise DataFileError(
                f"{path}: the session is still {session.status.value} (its writer stopped without "
                "finishing it); resume it before storing models"
            )
        if record.name in session.models and not force:
            raise DataFileError(
                f"{path}: already holds a model named {record.name!r}; use --force to replace it"
            )

    def edit(dst: h5py.File, session: Session) -> None:
        models = dst.require_group("models")
        replaced = record.name in models
        if replaced:
            del models[record.name]
        write_model_group(models, record)
        verb = "replaced" if replaced else "stored"
        append_event(dst["log"], session.status, "model", f"{verb} model {record.name} ({record.method})",
                     session.n_samples)

    rewrite_session(path, edit, check=check)
