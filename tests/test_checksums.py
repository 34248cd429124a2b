"""Checksums on everything that decides what is applied or identified: the plan (/excitation/inputs,
measure, curve), the samples, the stored models.  A flipped bit is a one-line error naming the dataset
(exit 2) for every command that reads a session -- identify, report, validate, export, --resume."""

from __future__ import annotations

import struct

import h5py
import numpy as np
import pytest

from drivers import SensorError, default_config, open_rig
from rig.acquisition import DwellSettings, FixedDwell, acquire, make_record, sequence_record
from sessions import DataFileError, read_session

from .cli import assert_one_line_error, rig_here
from .conftest import digest
from .faultkit import sensor_dies_after


def flip_bit(path, dataset: str, index: int, bit: int) -> tuple[float, float]:
    """Flip bit ``bit`` (0 = least significant) of float64 element ``index`` of ``dataset`` on disk, as a
    failing disk or a bad copy would; returns the value before and after."""
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        offset = ds.id.get_chunk_info(0).byte_offset if ds.chunks else ds.id.get_offset()
        before = float(ds[()].flat[index])
    where = offset + 8 * index
    with open(path, "r+b") as fh:
        fh.seek(where)
        raw = bytearray(fh.read(8))
        raw[bit // 8] ^= 1 << (bit % 8)
        fh.seek(where)
        fh.write(raw)
    return before, struct.unpack("<d", bytes(raw))[0]


def point_at(path, volts: float) -> int:
    return int(np.flatnonzero(read_session(path).excitation.inputs == volts)[0])


@pytest.fixture
def complete(tmp_path):
    path = tmp_path / "s.h5"
    assert rig_here("acquire", "--levels", 10, "--out", path).code == 0
    assert rig_here("identify", path, "--name", "ls").code == 0
    return path


def test_a_flipped_bit_in_the_plan_is_named_by_identify_report_and_validate(tmp_path, complete):
    k = point_at(complete, 2.4)  # 2.4 V = 1.2 x 2^1: the lowest exponent bit (52) doubles it
    assert flip_bit(complete, "excitation/inputs", k, 52) == (2.4, 4.8)
    before = digest(complete)
    for args in (["identify", complete, "--no-store"], ["report", complete, "--out", tmp_path / "r"],
                 ["validate", complete, "--on", complete], ["export", complete, "--csv", tmp_path / "x.csv"]):
        assert_one_line_error(rig_here(*args), "/excitation/inputs", "checksum")
    assert digest(complete) == before  # only ever read


def test_a_flipped_bit_in_a_stored_model_is_named(complete):
    flip_bit(complete, "models/ls/density", 0, 62)
    assert_one_line_error(rig_here("validate", complete, "--on", complete), "/models/ls/density", "checksum")


def test_a_flipped_bit_in_the_plan_of_an_interrupted_run_stops_resume(tmp_path):
    """2.8 V becomes 5.6 V, still inside the heater's window: only the checksum can tell."""
    path = tmp_path / "cut.h5"
    settings = DwellSettings(FixedDwell(20.0), readings=1)
    with open_rig(default_config(levels=8, psd_noise_V=0.0)) as rig:
        with pytest.raises(SensorError):
            acquire(rig, make_record(sequence_record("damped", rig.heater.window, levels=8), settings), path,
                    hooks=sensor_dies_after(rig, 5))
    s = read_session(path)
    later = [k for k in range(s.n_samples, s.excitation.n_points) if s.excitation.inputs[k] == 2.25]
    assert later, s.excitation.inputs
    assert flip_bit(path, "excitation/inputs", later[0], 52) == (2.25, 4.5)
    before = digest(path)
    assert_one_line_error(rig_here("acquire", "--resume", path), "/excitation/inputs", "checksum")
    assert digest(path) == before
    with pytest.raises(DataFileError, match="/excitation/inputs"):
        read_session(path)
