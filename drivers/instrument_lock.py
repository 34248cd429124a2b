"""One run per instrument: an advisory lock per instrument address, held while a rig is open.

Two programs driving one heater at once both "complete", with wrong data
(each moves the other's set-points), and the second one's opening 0 V
already lands in the middle of the first one's run.  So :func:`drivers.open_rig`
takes a lock named after the instrument's address -- ``modbus 192.0.2.10:502
unit 1``, ``serial /dev/ttyUSB0`` (the device path resolved, so its
``/dev/serial/by-id`` alias is the same instrument) -- *before* it connects,
and a second rig on the same address is refused with :class:`InstrumentBusy`
naming the holder (pid, command line, since when).

The lock is ``flock`` on a small file in the lock directory (``$RIG_LOCK_DIR``,
else ``/run/lock/vo2rig``, else ``vo2rig-locks`` in the system's temporary
directory), which also holds the holder's description.  The kernel drops it
when the process ends however it ends, so a crashed run never blocks the next.
It is advisory: it keeps ``rig`` processes apart, not other programs.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import ipaddress
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

from .errors import InstrumentBusy


def host_port(host: str, port: int) -> str:
    """``host:port`` in one spelling per address: ``localhost`` and ``127.0.0.1`` are the same, and so
    are the forms of one IPv6 address (no name is looked up)."""
    h = host.strip().strip("[]").lower()
    if h == "localhost":
        h = "127.0.0.1"
    try:
        h = str(ipaddress.ip_address(h))
    except ValueError:
        pass
    return f"[{h}]:{port}" if ":" in h else f"{h}:{port}"


def serial_port_name(url: str) -> str:
    """A serial port in one spelling: a device path resolved through its symlinks, a ``socket://`` URL's
    address normalised; anything else as given."""
    if url.startswith("socket://"):
        host, _, port = url.removeprefix("socket://").rpartition(":")
        return f"socket://{host_port(host, int(port))}" if port.isdigit() else url
    if "://" in url:
        return url
    return os.path.realpath(url)


def lock_directory() -> Path:
    """Where instrument locks live (created on first use)."""
    given = os.environ.get("RIG_LOCK_DIR")
    if given:
        d = Path(given)
    elif os.access("/run/lock", os.W_OK):
        d = Path("/run/lock/vo2rig")
    else:
        d = Path(tempfile.gettempdir()) / "vo2rig-locks"
    if not d.is_dir():
        d.mkdir(parents=True, exist_ok=True)
        if not given:
            try:
                os.chmod(d, 0o1777)  # every user's runs lock here (sticky: nobody removes another's file)
            except OSError:
                pass
    return d


def _file_name(address: str) -> str:
    readable = re.sub(r"[^A-Za-z0-9.-]+", "_", address).strip("_")[:80]
    return f"{readable}-{hashlib.sha256(address.encode()).hexdigest()[:12]}.lock"


class InstrumentLock:
    """The lock of one instrument address; :meth:`acquire` takes it or raises :class:`InstrumentBusy`."""

    def __init__(self, address: str, directory: Path | None = None) -> None:
        self.address = address
        self.path = (directory or lock_directory()) / _file_name(address)
        self._fd: int | None = None

    def acquire(self, purpose: str | None = None) -> "InstrumentLock":
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = _read_holder(fd)
            os.close(fd)
            if exc.errno in (errno.EAGAIN, errno.EACCES):
                raise InstrumentBusy(
                    f"{self.address} is in use by another run ({holder}); one run per instrument: wait for it "
                    "to finish, or stop it"
                ) from None
            raise
        holder = {
            "pid": os.getpid(),
            "command": purpose or " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])[:300],
            "since": time.strftime("%Y-%m-%d %H:%M:%S"),
            "address": self.address,
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(holder).encode(), 0)
        self._fd = fd
        return self

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the description releases the flock
            self._fd = None


def _read_holder(fd: int) -> str:
    try:
        data = json.loads(os.pread(fd, 4096, 0) or b"{}")
        return f"pid {data['pid']}: {data['command']}, since {data['since']}"
    except (OSError, ValueError, KeyError, TypeError):
        return "its holder did not say who it is"
