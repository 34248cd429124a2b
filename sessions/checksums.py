"""Checksums on every dataset that decides what is applied or identified.

The plan (``/excitation/inputs``, ``measure``, ``curve``), the samples, the
drift-monitor table and every stored model's ``walls``, ``density`` and
``rows`` are written with HDF5's Fletcher-32 filter, which HDF5 verifies on
every read -- in this program and in any other HDF5 tool.  A flipped bit
(a failing disk, a bad copy) then stops every command that reads the
session with one line naming the dataset, instead of, say, a plan point of
2.8 V silently becoming 5.6 V on ``--resume``.  (HDF5's metadata, the
attributes included, carries its own checksums in the file format used.)

Files written before the checksums were added read as before, unverified.

``/samples`` grows one row at a time, and every append rewrites its last
chunk whole (rows, then the checksum at the chunk's end).  A writer killed
in the middle of that write (SIGKILL lands inside the ``write`` call, which
the kernel may cut at a page boundary) leaves a chunk whose checksum fails.
Nothing in it is lost: the rows before the one being appended are the same
bytes in the old and the new version of the chunk, and HDF5's single-writer
mode writes raw data before the table length that makes a row visible, so
every row within the length on disk was whole before the cut.
:func:`read_appended` reads such a chunk's rows unverified, and only that
chunk, only up to the table's length, and only when the caller says the
writer may have died in an append (a session still ``running``).
"""

from __future__ import annotations

from typing import Any

import h5py
import numpy as np

from .errors import DataFileError


def create_checked(parent: h5py.Group, name: str, data: Any) -> h5py.Dataset:
    """``parent/name`` holding ``data``, in one chunk with a Fletcher-32 checksum (contiguous when empty:
    there is nothing to check and HDF5 cannot chunk it)."""
    arr = np.asarray(data)
    if arr.size == 0:
        return parent.create_dataset(name, data=arr)
    return parent.create_dataset(name, data=arr, chunks=arr.shape, fletcher32=True)


def _failed_checksum(exc: OSError, ds: h5py.Dataset) -> bool:
    return "filter returned failure" in str(exc) and bool(ds.fletcher32)


def _checksum_error(ds: h5py.Dataset) -> DataFileError:
    return DataFileError(
        f"{ds.name} fails its checksum: its data changed on disk or in a copy, so it cannot be trusted "
        "(restore the file from a good copy)"
    )


def read_checked(ds: h5py.Dataset) -> np.ndarray:
    """All of ``ds``; a checksum that fails is a :class:`DataFileError` naming the dataset."""
    try:
        return ds[()]
    except OSError as exc:
        if _failed_checksum(exc, ds):
            raise _checksum_error(ds) from None
        raise


def read_appended(ds: h5py.Dataset, start: int = 0, *, cut_append: bool = False) -> tuple[np.ndarray, bool]:
    """Rows ``start:`` of a 1-D table grown by appends (``/samples``), and whether its last chunk was cut.

    With ``cut_append`` (the writer may have died inside an append), a last
    chunk whose checksum fails is read unverified up to the table's length
    (see the module's docstring); every other checksum failure -- an earlier
    chunk, a table with other filters, a table whose writer finished -- is
    a :class:`DataFileError` naming the dataset.
    """
    stop = int(ds.shape[0])
    try:
        return ds[start:stop], False
    except OSError as exc:
        if not _failed_checksum(exc, ds):
            raise
    if not cut_append or stop == 0 or ds.compression is not None or ds.shuffle or ds.scaleoffset is not None:
        raise _checksum_error(ds)
    rows_per_chunk = int(ds.chunks[0])
    last = (stop - 1) // rows_per_chunk * rows_per_chunk  # the chunk holding the table's final row
    try:
        head = ds[start:last] if last > start else ds[0:0]
        mask, data = ds.id.read_direct_chunk((last,))
    except OSError as exc:
        if _failed_checksum(exc, ds):
            raise _checksum_error(ds) from None
        raise
    if mask != 0 or len(data) != rows_per_chunk * ds.dtype.itemsize + 4:  # the rows, then Fletcher-32's 4 bytes
        raise _checksum_error(ds)
    tail = np.frombuffer(data, dtype=ds.dtype, count=rows_per_chunk)[max(start, last) - last : stop - last]
    return np.concatenate([head, tail]), True
