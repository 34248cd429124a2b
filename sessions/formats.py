"""What a data file holds, judged by its content, never by its name.

A command that takes "a session or a CSV trace" must not call a damaged
session "not a text CSV file" because it failed the HDF5 check: it reads the
first bytes, says what the file is, and only then hands it to the reader of
that format.  :func:`detect` names the kind; :func:`not_a_run` is the
one-line message for a file that is neither a session nor a CSV trace.
"""

from __future__ import annotations

import enum
import os
from pathlib import Path

from .textfiles import reading

#: The 8-byte HDF5 format signature; HDF5 looks for it at offset 0, 512, 1024, 2048, ...
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Bytes read to tell text from binary data.
SNIFF_BYTES = 8192
#: File name endings of HDF5 files (sessions), used only to phrase a message.
HDF5_SUFFIXES = (".h5", ".hdf5", ".he5")


class FileKind(enum.Enum):
    """What the first bytes of a file say it is."""

    HDF5 = "an HDF5 file"
    TEXT = "a text file"
    MICROMAG = "a MicroMag FORC data file"
    JSON = "a JSON file"
    BINARY = "binary data"
    EMPTY = "an empty file"


def _has_hdf5_signature(fh, size: int) -> bool:
    offset = 0
    while offset + len(HDF5_SIGNATURE) <= size:
        fh.seek(offset)
        if fh.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE:
            return True
        offset = 512 if offset == 0 else 2 * offset
    return False


#: Bytes that do not occur in text (C0 controls but tab, newlines and form feed; DEL).
_CONTROL = bytes(b for b in range(32) if b not in b"\t\n\r\f") + b"\x7f"


def _is_text(head: bytes) -> bool:
    """Whether ``head`` looks like text: no NUL, and hardly any control bytes (any encoding)."""
    if b"\0" in head:
        return False
    controls = len(head) - len(head.translate(None, _CONTROL))
    return controls <= 0.01 * len(head)


def detect(path: str | os.PathLike) -> FileKind:
    """The kind of file at ``path``, from its content; :class:`DataFileError` if it cannot be read."""
    path = Path(path)
    with reading(path, "a data file"), path.open("rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        if size == 0:
            return FileKind.EMPTY
        if _has_hdf5_signature(fh, size):
            return FileKind.HDF5
        fh.seek(0)
        head = fh.read(SNIFF_BYTES)
    if not _is_text(head):
        return FileKind.BINARY
    start = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if start.lower().startswith(b"micromag"):
        return FileKind.MICROMAG
    if start[:1] in (b"{", b"["):
        return FileKind.JSON
    return FileKind.TEXT


def not_a_run(path: str | os.PathLike, kind: FileKind) -> str:
    """One line saying that ``path`` (of ``kind``) is neither a session nor a CSV trace, and what to do."""
    path = Path(path)
    if kind is FileKind.MICROMAG:
        return (f"{path}: a MicroMag FORC data file, not a session or a CSV trace; import it first: "
                f"rig import {path} --format micromag --out SESSION.h5")
    if kind is FileKind.JSON:
        return f"{path}: a JSON file (a model file?), not a session (HDF5) or a CSV trace"
    if kind is FileKind.BINARY:
        named = " although named like one" if path.suffix.lower() in HDF5_SUFFIXES else ""
        return (f"{path}: binary data without an HDF5 signature: not a session{named} (damaged, truncated or "
                f"another format) and not a CSV trace (text)")
    raise ValueError(f"{kind} may be a session or a CSV trace")
