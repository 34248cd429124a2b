"""Surviving storage faults while a session is written: a disk that fills, an I/O error, a file removed.

Three small tools used by :class:`sessions.SessionWriter`:

* :class:`Reserve` -- a few hundred KiB allocated beside the session when a
  run starts and freed the moment a write fails, so that on a full disk
  there is still room to log ``failed`` and close the file properly
  (HDF5 must write its last metadata to close a file);
* :func:`abandon` -- the last resort when even that fails (an I/O error):
  the file's descriptor is pointed at ``/dev/null`` before HDF5 closes it,
  so HDF5 completes its close instead of crashing the process at exit (it
  segfaults re-trying a failed flush during library shutdown); the file
  on disk stays as it was after the last successful flush, which the
  single-writer/multiple-reader mode keeps readable;
* :func:`storage_reason` -- the one-line cause of an h5py or OS write error.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
from pathlib import Path

#: Bytes set aside beside a session while it is written (a new log chunk and HDF5's closing metadata
#: take some tens of KiB).
RESERVE_BYTES = 128 * 1024

_H5_REASON = re.compile(r"error message = '([^']*)'")


def storage_reason(exc: BaseException) -> str:
    """Why a write failed, in a few words ("No space left on device"), from an OSError or h5py's text."""
    text = str(exc)
    m = _H5_REASON.search(text)
    if m:
        return m.group(1)
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return " ".join(text.split())[:200] or type(exc).__name__


#: Bytes a new session needs beyond its plan before the first sample: HDF5's metadata, the first chunks of
#: ``/samples`` (256 rows) and ``/log`` (16 events), the attributes.
LAYOUT_BYTES = 96 * 1024


def check_free_space(path: Path, n_points: int, reserve: int = RESERVE_BYTES) -> None:
    """Refuse to start writing a session of ``n_points`` planned points where the disk cannot even hold its
    layout and the reserve: an HDF5 write that fails while objects are being created can leave the
    library in a state where it crashes the process, so that must not be the first write to fail."""
    try:
        free = shutil.disk_usage(path.parent).free
    except OSError:
        return  # unknown: the writes will tell
    need = reserve + LAYOUT_BYTES + 16 * n_points
    if free < need:
        raise OSError(errno.ENOSPC, f"No space left on device (needs {need // 1024} KiB, {free // 1024} KiB free)")


def reserve_path(path: Path) -> Path:
    """The hidden reserve file of the session at ``path``."""
    return path.with_name(f".{path.name}.reserve")


class Reserve:
    """Space set aside beside a session, freed when a write fails (see the module doc)."""

    def __init__(self, path: Path, size: int = RESERVE_BYTES) -> None:
        self.path = reserve_path(path)
        self.size = size
        self.held = False

    def take(self) -> "Reserve":
        """Allocate the space; :class:`OSError` (ENOSPC) when the disk cannot spare it."""
        if self.size <= 0:
            return self
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o600)
        try:
            try:
                os.posix_fallocate(fd, 0, self.size)
            except OSError as exc:
                if exc.errno not in (errno.EOPNOTSUPP, errno.EINVAL):
                    raise
                os.write(fd, bytes(self.size))  # a file system without fallocate: real blocks
        except BaseException:
            os.close(fd)
            self.path.unlink(missing_ok=True)
            raise
        os.close(fd)
        self.held = True
        return self

    def free(self) -> None:
        """Give the space back (idempotent)."""
        if self.held or self.path.exists():
            try:
                self.path.unlink()
            except OSError:
                pass
            self.held = False


def abandon(fd: int | None, close) -> None:
    """Close an HDF5 file whose writes fail without letting HDF5 crash: its descriptor ``fd`` is pointed
    at ``/dev/null`` first, then ``close()`` is called (errors ignored)."""
    if fd is not None:
        try:
            null = os.open(os.devnull, os.O_RDWR | os.O_CLOEXEC)
            os.dup2(null, fd)
            os.close(null)
        except OSError:
            pass
    try:
        close()
    except Exception:
        pass
