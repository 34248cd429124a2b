"""Text data files (CSV traces, MicroMag files): their bytes and the numbers in them, or a one-line
:class:`DataFileError` naming the file, the line and what is wrong."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from pathlib import Path

from .errors import DataFileError


@contextlib.contextmanager
def reading(path: Path, kind: str) -> Iterator[None]:
    """Turn the reasons the OS gives for not reading ``path`` into one :class:`DataFileError` naming the
    file; ``kind`` names what it should be (``"a CSV file"``)."""
    try:
        yield
    except FileNotFoundError:
        raise DataFileError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise DataFileError(f"{path}: is a directory, not {kind}") from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot read ({exc.strerror})") from None


def read_bytes(path: Path, kind: str) -> bytes:
    """The bytes of the file at ``path``; ``kind`` names what it should be (``"a CSV file"``)."""
    with reading(path, kind):
        return path.read_bytes()


def finite_number(text: str, where: str, name: str) -> float:
    """``text`` as a finite float; otherwise :class:`DataFileError`
    ``"{where}: {name} value '{text}' is not a number"`` (or ``is not finite``).

    ``where`` names the place, e.g. ``"run.csv: line 7"``.
    """
    try:
        value = float(text)
    except ValueError:
        raise DataFileError(f"{where}: {name} value {text!r} is not a number") from None
    if not math.isfinite(value):
        raise DataFileError(f"{where}: {name} value {text!r} is not finite")
    return value
