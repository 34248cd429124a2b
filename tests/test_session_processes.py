"""Sessions across real processes: SIGKILL mid-run, a live reader, a killed rewrite."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sessions import DataFileError, SessionFollower, SessionWriter, Status, add_model, read_session
from sessions.lock import held_by_other
from sessions.rewrite import rewrite_path

from .conftest import digest
from .sessionkit import append_point, assert_rows_as_written
from .test_sessions import fitted_record, write_session

CHILD = Path(__file__).with_name("session_child.py")


def start_child(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, str(CHILD), *map(str, args)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def read_reported(child: subprocess.Popen, until: int) -> list[int]:
    """Indices the child reported as taken, reading until ``until`` of them."""
    reported = []
    while len(reported) < until:
        line = child.stdout.readline()
        assert line, child.stderr.read()
        reported.append(int(line))
    return reported


def kill(child: subprocess.Popen) -> None:
    os.kill(child.pid, signal.SIGKILL)
    child.wait(timeout=30)
    for stream in (child.stdin, child.stdout, child.stderr):
        stream.close()


@pytest.mark.parametrize("after", [1, 57, 300])
def test_sigkill_mid_run_keeps_every_reported_sample_and_resumes(tmp_path, after):
    """The child appends as fast as it can; SIGKILL lands in or between appends."""
    path = tmp_path / "run.h5"
    planned = 20_000  # seconds of appending: the kill always lands mid-run
    child = start_child("write", path, planned, 0.0)
    reported = read_reported(child, after)
    kill(child)
    assert child.returncode == -signal.SIGKILL
    assert reported == list(range(after))
    before = digest(path)
    s = read_session(path)  # the file is still marked "open for writing" by the dead writer
    assert digest(path) == before
    assert s.status is Status.RUNNING and not s.writer_alive()
    # every reported sample is there, plus any taken after the last report we read
    assert after <= s.n_samples < planned
    assert_rows_as_written(s.samples)
    # and the session continues where it stopped
    with SessionWriter.reopen(path, reason="after SIGKILL") as w:
        start = w.count
        assert start == s.n_samples
        for k in range(start, start + 10):
            append_point(w, k)
        w.finish(Status.ABORTED, "enough")
    done = read_session(path)
    assert done.status is Status.ABORTED and done.n_samples == start + 10
    assert_rows_as_written(done.samples, start + 10)
    assert [e.event for e in done.events] == ["created", "reopened", "aborted"]


@pytest.mark.slow
def test_second_process_reads_while_the_writer_appends(tmp_path):
    path = tmp_path / "live.h5"
    child = start_child("write", path, 60, 0.01, "hold")
    try:
        read_reported(child, 1)
        seen = []
        with SessionFollower(path) as follower:
            assert follower.status is Status.RUNNING
            deadline = time.monotonic() + 60
            while follower.samples.size < 60 and time.monotonic() < deadline:
                new = follower.poll()
                if new.size:
                    seen.append(new.size)
                    assert_rows_as_written(follower.samples)
                time.sleep(0.005)
            assert follower.samples.size == 60
            assert len(seen) > 1  # it really saw the file grow, not just the end
            snapshot = read_session(path)  # a whole read while the writer is alive
            assert snapshot.status is Status.RUNNING and snapshot.writer_alive()
            assert_rows_as_written(snapshot.samples, 60)
            assert read_reported(child, 59) == list(range(1, 60))
            assert child.stdout.readline().strip() == "held"
            child.stdin.write("go\n")
            child.stdin.flush()
            assert child.stdout.readline().strip() == "done"
            assert follower.status is Status.COMPLETE
        assert child.wait(timeout=30) == 0
    finally:
        if child.poll() is None:
            kill(child)


def test_a_live_writer_is_never_replaced_or_rewritten(tmp_path):
    path = tmp_path / "live.h5"
    child = start_child("write", path, 5, 0.0, "hold")
    try:
        read_reported(child, 5)
        assert child.stdout.readline().strip() == "held"
        assert held_by_other(path)
        for attempt in (lambda: add_model(path, fitted_record()), lambda: SessionWriter.reopen(path)):
            with pytest.raises(DataFileError, match="being written by another process"):
                attempt()
    finally:
        kill(child)
    assert not held_by_other(path)  # the kernel dropped the dead writer's lock


def test_sigkill_during_a_model_rewrite_leaves_the_original(tmp_path):
    path = write_session(tmp_path / "s.h5")
    before = digest(path)
    child = start_child("kill-in-rewrite", path, "doomed")
    child.communicate(timeout=60)
    assert child.returncode == -signal.SIGKILL
    assert digest(path) == before
    assert rewrite_path(path).exists()  # the half-made copy, never renamed
    s = read_session(path)
    assert s.models == {} and s.status is Status.COMPLETE
    add_model(path, fitted_record("kept"))  # the next rewrite replaces the leftover
    assert list(read_session(path).models) == ["kept"] and not rewrite_path(path).exists()


def test_a_torn_copy_of_a_live_session_fails_fast(tmp_path):
    """Marked 'open for writing' and truncated: an error, not HDF5's endless retries."""
    path = tmp_path / "live.h5"
    child = start_child("write", path, 300, 0.0, "hold")
    read_reported(child, 300)
    assert child.stdout.readline().strip() == "held"
    kill(child)
    size = path.stat().st_size
    os.truncate(path, size // 2)
    start = time.monotonic()
    with pytest.raises(DataFileError, match="corrupt|truncated"):
        read_session(path)
    assert time.monotonic() - start < 10


def documented_recipe() -> str:
    """The Python block docs/sessions.md gives for reading a session whose writer died."""
    text = (Path(__file__).parents[1] / "docs" / "sessions.md").read_text(encoding="utf-8")
    marker = "<!-- recipe: crashed session -->"
    assert marker in text, "docs/sessions.md does not say how to open a crashed session with other tools"
    block = text.split(marker, 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    return block


def test_the_documented_way_opens_a_crashed_session_with_plain_h5py_and_hdf5_tools(tmp_path, capsys):
    import shutil

    import h5py

    path = tmp_path / "crashed.h5"
    child = start_child("write", path, 20_000, 0.0)
    reported = read_reported(child, 40)
    kill(child)
    before = digest(path)
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(path, "r")  # the plain way: refused, as the docs say
    exec(documented_recipe(), {"path": path})
    out = capsys.readouterr().out
    n = int(out.split()[0])
    assert n >= len(reported) and out.strip() == f"{n} samples, status running"
    assert digest(path) == before  # nothing was written
    if shutil.which("h5clear") and shutil.which("h5dump"):
        copy = tmp_path / "copy.h5"
        shutil.copy2(path, copy)
        assert subprocess.run(["h5clear", "-s", str(copy)], capture_output=True, timeout=60).returncode == 0
        dump = subprocess.run(["h5dump", "-H", str(copy)], capture_output=True, text=True, timeout=60)
        assert dump.returncode == 0 and "samples" in dump.stdout
        with h5py.File(copy, "r") as f:
            assert f["samples"].shape[0] >= n
        assert digest(path) == before
