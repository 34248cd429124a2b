"""The writer's lock: at most one process writes (or rewrites) a session at a time.

HDF5 drops its own file lock when SWMR writing starts, so that readers can
open the file, and a file whose writer died still says "open for writing";
neither tells a live writer from a dead one.  So whoever writes a session
holds an *open file description* lock (Linux ``F_OFD_SETLK``) on it:

* the kernel releases it when the process ends, however it ends (SIGKILL
  included), so a crashed session is never "locked";
* unlike POSIX record locks it is not dropped when the same process opens
  and closes the file again (as HDF5 and the session reader do);
* it does not interact with HDF5's own ``flock()`` locks.

Where OFD locks do not exist (not Linux) locking is a no-op and
:func:`held_by_other` answers ``False``.
"""

from __future__ import annotations

import errno
import fcntl
import os
import struct
from pathlib import Path

from .errors import DataFileError

_SETLK = getattr(fcntl, "F_OFD_SETLK", None)
_GETLK = getattr(fcntl, "F_OFD_GETLK", None)
#: struct flock {short l_type, l_whence; off_t l_start, l_len; pid_t l_pid;} (+ padding)
_FLOCK = "hhqqi4x"


def _flock(kind: int) -> bytes:
    return struct.pack(_FLOCK, kind, os.SEEK_SET, 0, 0, 0)  # whole file; l_pid must be 0


class WriterLock:
    """An exclusive lock on a session file, held while writing it."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self._fd: int | None = None

    def acquire(self) -> "WriterLock":
        """Take the lock or raise :class:`DataFileError` if another process holds it.

        A file without any write permission bit counts as read-only even for
        root: an archived session is not to be changed.
        """
        try:
            if not self.path.stat().st_mode & 0o222:
                raise PermissionError
            fd = os.open(self.path, os.O_RDWR | os.O_CLOEXEC)
        except PermissionError:
            raise DataFileError(f"{self.path}: is read-only; it will not be modified") from None
        except OSError as exc:
            raise DataFileError(f"{self.path}: cannot open for writing ({exc.strerror})") from None
        if _SETLK is not None:
            try:
                fcntl.fcntl(fd, _SETLK, _flock(fcntl.F_WRLCK))
            except OSError as exc:
                os.close(fd)
                if exc.errno in (errno.EAGAIN, errno.EACCES):
                    raise DataFileError(
                        f"{self.path}: is being written by another process; it was not modified"
                    ) from None
                raise
        self._fd = fd
        return self

    @property
    def fd(self) -> int | None:
        """The descriptor of the locked file (None when not held)."""
        return self._fd

    def still_names_the_file(self) -> bool:
        """Whether the path still refers to the locked file (not replaced meanwhile)."""
        try:
            a, b = os.stat(self.path), os.fstat(self._fd)
        except (OSError, TypeError):
            return False
        return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the description releases an OFD lock
            self._fd = None

    def __enter__(self) -> "WriterLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def held_by_other(path: str | os.PathLike) -> bool:
    """Whether some other open file description holds the writer's lock on ``path``."""
    if _GETLK is None:
        return False
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        answer = fcntl.fcntl(fd, _GETLK, _flock(fcntl.F_WRLCK))
    finally:
        os.close(fd)
    return struct.unpack(_FLOCK, answer)[0] != fcntl.F_UNLCK
