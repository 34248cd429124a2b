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


def read_checked(ds: h5py.Dataset) -> np.ndarray:
    """All of ``ds``; a checksum that fails is a :class:`DataFileError` naming the dataset."""
    try:
        return ds[()]
    except OSError as exc:
        if "filter returned failure" in str(exc) and ds.fletcher32:
            raise DataFileError(
                f"{ds.name} fails its checksum: its data changed on disk or in a copy, so it cannot be trusted "
                "(restore the file from a good copy)"
            ) from None
        raise
