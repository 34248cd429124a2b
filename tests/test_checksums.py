"""Checksums on everything that decides what is applied or identified: the plan (/excitation/inputs,
measure, curve), the samples, the stored models.  A flipped bit is a one-line error naming the dataset
(exit 2) for every command that reads a session -- identify, report, validate, export, --resume."""

from __future__ import annotations

import shutil
import struct

import h5py
import numpy as np
import pytest

from drivers import SensorError, default_config, open_rig
from rig.acquisition import DwellSettings, FixedDwell, acquire, make_record, sequence_record
from sessions import DataFileError, SessionFollower, SessionWriter, Status, read_session
from sessions.checksums import read_checked
from sessions.reader import open_hdf5
from sessions.schema import SAMPLE_CHUNK

from .cli import assert_one_line_error, rig_here
from .conftest import digest
from .faultkit import sensor_dies_after
from .sessionkit import append_point, assert_rows_as_written, excitation


def flip_bit(path, dataset: str, index: int, bit: int) -> tuple[float, float]:
    """Flip bit ``bit`` (0 = least significant) of float64 element ``index`` of ``dataset`` on disk, as a
    failing disk or a bad copy would; returns the value before and after."""
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        offset = ds.id.get_chunk_info(0).byte_offset if ds.chunks else ds.id.get_offset()
        before = float(ds[()].flat[index])
    where = offset + 8 * index
    flip_file_bit(path, where + bit // 8, bit % 8)
    with open(path, "rb") as fh:
        fh.seek(where)
        return before, struct.unpack("<d", fh.read(8))[0]


def flip_file_bit(path, where: int, bit: int) -> None:
    """Flip bit ``bit`` of the byte at file offset ``where``."""
    with open(path, "r+b") as fh:
        fh.seek(where)
        b = fh.read(1)[0]
        fh.seek(where)
        fh.write(bytes([b ^ (1 << bit)]))


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


# ---------------------------------------------------------------- an append cut by the writer's death
def cut_append(tmp_path, rows: int, cut_bytes: int = 8192):
    """A session as SIGKILL leaves it inside an append: on-disk state before point ``rows`` was appended,
    except that the first ``cut_bytes`` of /samples' last chunk already hold the chunk written by that
    append (the kernel cuts a killed ``write`` at a page boundary; the checksum sits at the chunk's end)."""
    path, before, after = tmp_path / "run.h5", tmp_path / "before.h5", tmp_path / "after.h5"
    writer = SessionWriter.create(path, excitation(600), fsync_interval_s=None)
    for k in range(rows):
        append_point(writer, k)
    shutil.copyfile(path, before)
    append_point(writer, rows)
    shutil.copyfile(path, after)
    writer.finish()
    chunk = rows // SAMPLE_CHUNK
    with open_hdf5(before) as a, open_hdf5(after) as b:
        old, new = (f["samples"].id.get_chunk_info(chunk) for f in (a, b))
    assert (old.byte_offset, old.size) == (new.byte_offset, new.size)  # rewritten in place, as the recovery assumes
    with open(after, "rb") as fh:
        fh.seek(new.byte_offset)
        head = fh.read(cut_bytes)
    with open(before, "r+b") as fh:
        fh.seek(old.byte_offset)
        fh.write(head)
    return before


@pytest.mark.parametrize("rows", [116, 300])
def test_an_append_cut_by_the_writers_death_keeps_every_row_before_it_and_resumes_checked(tmp_path, rows):
    path = cut_append(tmp_path, rows)
    before = digest(path)
    s = read_session(path)
    assert digest(path) == before
    assert s.status is Status.RUNNING and s.cut_append and s.n_samples == rows
    assert_rows_as_written(s.samples)
    follower = SessionFollower(path)  # the live reader sees the same rows
    assert_rows_as_written(follower.poll(), rows)
    with SessionWriter.reopen(path, reason="after SIGKILL") as w:
        assert w.count == rows
        for k in range(rows, rows + 5):
            append_point(w, k)
        w.finish(Status.ABORTED, "enough")
    done = read_session(path)
    assert not done.cut_append and done.n_samples == rows + 5
    assert_rows_as_written(done.samples)
    assert "cut by the writer's death" in done.events[1].message
    with h5py.File(path, "r") as f:  # every chunk verifies again
        read_checked(f["samples"])


def flip_sample_byte(path, chunk: int, byte: int = 10) -> None:
    with open_hdf5(path) as f:
        offset = f["samples"].id.get_chunk_info(chunk).byte_offset
    flip_file_bit(path, offset + byte, 0)


def test_a_failing_chunk_before_the_last_or_in_a_finished_session_is_still_an_error(tmp_path):
    running = cut_append(tmp_path, 300, cut_bytes=0)  # the last chunk is whole ...
    flip_sample_byte(running, 0)  # ... the first one met a failing disk: a cut append never touches it
    finished = tmp_path / "done.h5"
    with SessionWriter.create(finished, excitation(300), fsync_interval_s=None) as w:
        for k in range(300):
            append_point(w, k)
        w.finish()
    flip_sample_byte(finished, 1)  # the last chunk, but its writer finished: nothing was cut
    for path in (running, finished):
        before = digest(path)
        with pytest.raises(DataFileError, match="/samples fails its checksum"):
            read_session(path)
        assert digest(path) == before
