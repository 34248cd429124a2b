"""Session files: what the writer stores, what the reader gives back, models, locking."""

import os

import h5py
import numpy as np
import pytest

from identify import Grid, PreisachModel
from identify.fit import fit_sequence
from sessions import (
    SCHEMA_VERSION,
    DataFileError,
    ExcitationRecord,
    ModelRecord,
    Quantities,
    SessionWriter,
    Status,
    add_model,
    read_session,
)
from sessions.lock import WriterLock, held_by_other
from sessions.log import fixed_text
from sessions.rewrite import rewrite_path

from .conftest import digest, known_model
from .sessionkit import append_point, assert_rows_as_written, excitation


def write_session(path, n=12, planned=None, **kwargs):
    with SessionWriter.create(path, excitation(planned or n), **kwargs) as w:
        for k in range(n):
            assert append_point(w, k) == k
    return path


def test_round_trip_of_everything_stored(tmp_path):
    path = tmp_path / "s.h5"
    exc = excitation(12)
    config = {"heater": {"port": "/dev/ttyUSB0", "max_V": 6.0}, "psd": {"gain": 2.5}}
    driver = {"heater": "sim", "sensor": "sim", "seed": 3}
    with SessionWriter.create(path, exc, operator="ada", notes="first run\nafter cleaning",
                              rig_config=config, driver=driver) as w:
        for k in range(12):
            append_point(w, k)
        w.log("paused", "operator pause")
    s = read_session(path)
    assert s.schema_version == SCHEMA_VERSION and s.software_version
    assert s.operator == "ada" and s.notes == "first run\nafter cleaning"
    assert s.rig_config == config and s.driver == driver
    assert s.quantities == Quantities()
    assert s.status is Status.COMPLETE and not s.is_partial
    assert s.started_at <= s.ended_at
    assert [e.event for e in s.events] == ["created", "paused", "complete"]
    assert [e.status for e in s.events] == [Status.RUNNING, Status.RUNNING, Status.COMPLETE]
    assert s.events[1].n_samples == 12 and s.events[1].message == "operator pause"
    e = s.excitation
    assert (e.kind, e.levels, e.v_min, e.v_max, e.seed) == ("random", 10, 0.0, 6.0, 7)
    assert e.dwell == exc.dwell and s.grid == Grid(10, 0.0, 6.0)
    np.testing.assert_array_equal(e.inputs, exc.inputs)
    np.testing.assert_array_equal(e.measure, np.arange(12) % 3 != 1)
    assert_rows_as_written(s.samples, 12)
    np.testing.assert_array_equal(s.measured_rows, np.flatnonzero(np.arange(12) % 3 != 1))
    assert np.isnan(s.outputs[1]) and s.outputs[0] == 0.25


def test_layout_is_plain_hdf5(tmp_path):
    """What docs/sessions.md promises, read with h5py alone."""
    path = write_session(tmp_path / "s.h5", quantities=Quantities(input_unit="T", output_unit="A m^2"))
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == "vo2rig-session" and f.attrs["schema_version"] == SCHEMA_VERSION
        assert f.attrs["input_unit"] == "T" and f.attrs["output_unit"] == "A m^2"
        samples = f["samples"]
        assert samples.maxshape == (None,) and samples.chunks and samples.fletcher32
        assert samples.dtype.names == ("index", "t_s", "input", "output", "raw", "dwell_s",
                                       "settled", "measured", "flags")
        assert f["log"][-1]["status"] == b"complete"
        assert f["excitation/inputs"].shape == (12,) and f["excitation"].attrs["levels"] == 10
        assert f.id.get_create_plist().get_version()[0] >= 3  # superblock v3: SWMR-capable


def test_exception_marks_failed_and_keeps_samples(tmp_path):
    path = tmp_path / "s.h5"
    with pytest.raises(RuntimeError, match="driver fault"):
        with SessionWriter.create(path, excitation(10)) as w:
            for k in range(4):
                append_point(w, k)
            raise RuntimeError("driver fault: no reply from heater")
    s = read_session(path)
    assert s.status is Status.FAILED and s.is_partial and s.n_samples == 4
    assert "driver fault" in s.events[-1].message
    assert_rows_as_written(s.samples)


def test_keyboard_interrupt_marks_aborted(tmp_path):
    path = tmp_path / "s.h5"
    with pytest.raises(KeyboardInterrupt):
        with SessionWriter.create(path, excitation(10)) as w:
            append_point(w, 0)
            raise KeyboardInterrupt
    s = read_session(path)
    assert s.status is Status.ABORTED and s.n_samples == 1


def test_no_more_samples_than_planned_points(tmp_path):
    path = tmp_path / "s.h5"
    with SessionWriter.create(path, excitation(3)) as w:
        for k in range(3):
            append_point(w, k)
        with pytest.raises(DataFileError, match="all 3 planned points"):
            append_point(w, 3)
    assert read_session(path).n_samples == 3


def test_unmeasured_output_is_stored_as_nan(tmp_path):
    path = tmp_path / "s.h5"
    with SessionWriter.create(path, ExcitationRecord("file", [1.0, 2.0])) as w:
        w.append(0.0, 1.0, 5.0, measured=False)
        w.append(1.0, 2.0, 6.0)
    s = read_session(path)
    assert np.isnan(s.samples["output"][0]) and s.samples["output"][1] == 6.0
    assert s.grid is None


def test_never_overwrites_an_existing_file(tmp_path):
    path = write_session(tmp_path / "s.h5")
    before = digest(path)
    with pytest.raises(DataFileError, match="already exists"):
        SessionWriter.create(path, excitation(3))
    assert digest(path) == before


def test_lock_refuses_a_second_writer_while_the_first_writes(tmp_path):
    path = tmp_path / "s.h5"
    w = SessionWriter.create(path, excitation(5))
    append_point(w, 0)
    assert held_by_other(path)
    assert read_session(path).writer_alive()  # the reader is another open file description
    with pytest.raises(DataFileError, match="being written by another process"):
        WriterLock(path).acquire()
    with pytest.raises(DataFileError, match="being written by another process"):
        SessionWriter.reopen(path)
    w.finish(Status.ABORTED, "test")
    assert not held_by_other(path)
    assert read_session(path).status is Status.ABORTED


def test_reopen_continues_without_duplicating_or_skipping(tmp_path):
    path = tmp_path / "s.h5"
    w = SessionWriter.create(path, excitation(9))
    for k in range(4):
        append_point(w, k)
    w.finish(Status.ABORTED, "operator abort")
    with SessionWriter.reopen(path, reason="resume test") as w:
        assert w.count == 4
        for k in range(4, 9):
            append_point(w, k)
    s = read_session(path)
    assert s.status is Status.COMPLETE and s.n_samples == 9
    assert_rows_as_written(s.samples, 9)
    assert [e.event for e in s.events] == ["created", "aborted", "reopened", "complete"]
    assert s.events[2].message == "resume test" and s.events[2].n_samples == 4
    with pytest.raises(DataFileError, match="complete; there is nothing to resume"):
        SessionWriter.reopen(path)


def fitted_record(name="fit1", levels=4):
    truth = known_model(levels, v_min=0.0, v_max=6.0)
    v = np.linspace(0.0, 6.0, 40) ** 1.0
    v = np.concatenate([v, v[::-1], v[:25]])
    report = fit_sequence(truth.grid, v, truth.predict(v), "ls", measurements=60, seed=2)
    return ModelRecord.from_report(name, report, thermal_term=True, seed=2)


def test_model_round_trip_and_force(tmp_path):
    path = write_session(tmp_path / "s.h5")
    ended = read_session(path).ended_at
    rec = fitted_record()
    add_model(path, rec)
    s = read_session(path)
    assert s.ended_at == ended  # storing a model later does not move the end of the run
    got = s.models["fit1"]
    np.testing.assert_array_equal(got.model.density, rec.model.density)
    assert (got.model.mu0, got.model.c_d, got.model.grid) == (rec.model.mu0, rec.model.c_d, rec.model.grid)
    np.testing.assert_array_equal(got.rows, rec.rows)
    assert got.method == "ls" and got.seed == 2 and got.thermal_term is True
    assert got.metrics == rec.metrics and got.settings == rec.settings
    assert got.created_at == rec.created_at
    v = np.linspace(0, 6, 30)
    np.testing.assert_array_equal(got.model.predict(v), rec.model.predict(v))
    assert s.events[-1].event == "model" and s.status is Status.COMPLETE
    assert_rows_as_written(s.samples, 12)

    before = digest(path)
    with pytest.raises(DataFileError, match="already holds a model named 'fit1'"):
        add_model(path, fitted_record(levels=3))
    assert digest(path) == before
    add_model(path, fitted_record(levels=3), force=True)
    s = read_session(path)
    assert s.models["fit1"].model.grid.levels == 3 and list(s.models) == ["fit1"]
    add_model(path, fitted_record("fit2"))
    assert sorted(read_session(path).models) == ["fit1", "fit2"]
    assert not rewrite_path(path).exists()


@pytest.mark.parametrize("name", ["", "a/b", ".hidden", "x" * 65, "sp ace"])
def test_model_names_are_checked(name):
    with pytest.raises(DataFileError, match="model name"):
        ModelRecord(name, "ls", PreisachModel(Grid(1, 0, 1), [1.0]), rows=[0], thermal_term=False)


def test_models_only_in_finished_sessions(tmp_path):
    path = tmp_path / "s.h5"
    w = SessionWriter.create(path, excitation(5))
    append_point(w, 0)
    with pytest.raises(DataFileError, match="being written by another process"):
        add_model(path, fitted_record())
    w.close()  # closed without a final status: looks like a writer that died
    before = digest(path)
    with pytest.raises(DataFileError, match="still running"):
        add_model(path, fitted_record())
    assert digest(path) == before


def test_failed_edit_leaves_the_session_untouched(tmp_path):
    from sessions.rewrite import rewrite_session

    path = write_session(tmp_path / "s.h5")
    before = digest(path)

    def broken(dst, session):
        dst.create_group("models").create_group("half")
        raise OSError(28, "No space left on device")

    from sessions import StorageError

    with pytest.raises(StorageError, match=r"No space left on device\); the session was not modified"):
        rewrite_session(path, broken)
    assert digest(path) == before and not rewrite_path(path).exists()

    def drops_samples(dst, session):
        dst["samples"].resize((3,))

    with pytest.raises(DataFileError, match="lost samples"):
        rewrite_session(path, drops_samples)
    assert digest(path) == before and not rewrite_path(path).exists()


def test_read_only_session_is_not_rewritten(tmp_path):
    path = write_session(tmp_path / "s.h5")
    path.chmod(0o444)
    try:
        with pytest.raises(DataFileError, match="read-only"):
            add_model(path, fitted_record())
    finally:
        path.chmod(0o644)


def test_log_text_is_cut_on_character_boundaries():
    assert fixed_text("µm" * 10, 7) == "µm".encode() + b"..."
    assert fixed_text("short", 16) == b"short"


@pytest.mark.parametrize("interval, every_sample", [(0, True), (3600, False), (None, False)])
def test_fsync_every_sample_periodically_or_only_on_close(tmp_path, monkeypatch, interval, every_sample):
    """``fsync_interval_s=0`` syncs the session file inside every append; a long interval or ``None``
    only when the writer closes. Counted on the session file itself (by inode), so the test fails if
    syncing is switched off or goes to another file."""
    path = tmp_path / "s.h5"
    synced: list[tuple[str, int]] = []  # (what the writer was doing, inode synced)
    phase = ["create"]
    real_fsync = os.fsync

    def counting_fsync(fd):
        synced.append((phase[0], os.fstat(fd).st_ino))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", counting_fsync)
    with SessionWriter.create(path, excitation(12), fsync_interval_s=interval) as w:
        for k in range(12):
            phase[0] = f"append {k}"
            append_point(w, k)
        phase[0] = "close"
    inode = path.stat().st_ino
    appends = [what for what, ino in synced if what.startswith("append") and ino == inode]
    assert appends == ([f"append {k}" for k in range(12)] if every_sample else [])
    assert ("close", inode) in synced  # always on close
    assert read_session(path).n_samples == 12


def test_extend_matches_columns_by_name(tmp_path):
    path = tmp_path / "s.h5"
    other = np.dtype([("measured", "?"), ("output", "<f4"), ("input", "<f8"), ("t_s", "<f8"),
                      ("raw", "<f8"), ("dwell_s", "<f8"), ("settled", "?"), ("flags", "<u2"),
                      ("index", "<i4")])
    rows = np.zeros(3, other)
    rows["input"] = [1.0, 2.0, 3.0]
    rows["output"] = [10.0, 20.0, 30.0]
    rows["measured"] = [True, False, True]
    rows["t_s"] = [0.0, 1.0, 2.0]
    with SessionWriter.create(path, ExcitationRecord("file", [1.0, 2.0, 3.0])) as w:
        w.extend(rows)
    s = read_session(path)
    np.testing.assert_array_equal(s.inputs, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(s.outputs, [10.0, np.nan, 30.0])
    np.testing.assert_array_equal(s.samples["index"], [0, 1, 2])
