"""The fault-injection suite: ``rig acquire`` against ``rig serve-sim`` in real processes on loopback,
with faults injected from outside -- the server killed, hung (SIGSTOP) and continued, restarted in a
fresh state, bursts of signals, a full disk, a corrupted plan, two runs on one instrument.

Each test asserts three things: what the heater saw (the server's journal), what the session holds,
and what was printed.  Every wait is bounded (pytest-timeout, plus timeouts on every process)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rig.testing import Child
from sessions import SampleFlag, Status, read_session

from .acquirekit import wait_for_samples
from .cli import error_lines
from .conftest import digest
from .faultkit import FAULT_MAP, SimServer, rig_exe

#: The register map with the instrument's boot id (the simulated bench serves it at input 2).
BOOT_MAP = FAULT_MAP + "[modbus.boot_id]\naddress = 2\ntype = 'uint32'\n"

pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]

#: L = 8 on [1, 6] V (no point of the plan is 0 V, so a 0 V in the journal can only be the safe state);
#: 0.1 s dwells on the fast device; one reading per measurement.
RUN = ("--levels", 8, "--v-min", 1.0, "--dwell", 0.1, "--readings", 1)


@pytest.fixture(scope="module")
def shared_server(tmp_path_factory):
    """One server for the tests that do not break it (each reads the journal entries after its own start)."""
    with SimServer(tmp_path_factory.mktemp("shared")) as server:
        yield server


def one_line(err: str) -> str:
    lines = error_lines(err)
    assert "Traceback" not in err and len(lines) == 1, err
    return lines[0]


# ---------------------------------------------------------------- finding 1: never a false "heater at 0 V"
@pytest.mark.parametrize("fault", ["killed", "hung"])
def test_a_dead_or_hung_instrument_is_never_reported_at_0V(tmp_path, fault):
    with SimServer(tmp_path) as server:
        path = tmp_path / "run.h5"
        child = Child("--config", server.client_config(tmp_path / "rig.toml"), *RUN, "--out", path)
        wait_for_samples(path, 5, child=child)
        server.kill() if fault == "killed" else server.stop()
        try:
            code, out, err = child.finish(timeout=60)
            seen = server.accepted_volts()  # a hung server writes nothing more to its journal
        finally:
            server.cont()
        line = one_line(err)
        assert code == 3, err
        # the heater never saw a 0 V after the run started: it holds the last set-point
        assert seen[0] == 0.0 and min(seen[2:]) >= 1.0
        assert "heater at 0 V" not in line and "heater state unknown" in line.lower()
        assert f"{seen[-1]:g} V" in line  # what the instrument may still be holding
        s = read_session(path)
        assert s.status is Status.FAILED and s.n_samples >= 5
        msg = s.events[-1].message
        assert "heater at 0 V" not in msg and "heater state unknown" in msg.lower()


# ---------------------------------------------------------------- finding 3: signal bursts
def send_burst(pid: int, sig: int, count: int, gaps_s=None) -> int:
    """Send ``sig`` ``count`` times (``gaps_s``: the waits between them); returns how many were sent."""
    for k in range(count):
        try:
            os.kill(pid, sig)
        except ProcessLookupError:
            return k
        if gaps_s is not None and k < count - 1:
            time.sleep(gaps_s[k])
    return count


BURSTS = {
    "200 at once": (200, None),
    "15 spaced 10-50 ms": (15, np.random.default_rng(16).uniform(0.01, 0.05, 14)),
}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("burst", list(BURSTS))
def test_a_burst_of_signals_ends_aborted_with_exit_130_and_the_heater_at_0V(tmp_path, shared_server, sig, burst):
    count, gaps = BURSTS[burst]
    runs = 2 if gaps is None else 1
    server = shared_server
    cfg = server.client_config(tmp_path / "rig.toml")
    for run in range(runs):
        path = tmp_path / f"run{run}.h5"
        child = Child("--config", cfg, *RUN, "--out", path)
        wait_for_samples(path, 5, child=child)
        seen_before = len(server.accepted_volts())
        send_burst(child.proc.pid, sig, count, gaps)
        code, out, err = child.finish(timeout=60)
        assert code == 130, (run, code, err)
        assert "Traceback" not in err and "internal error" not in err
        last = [ln for ln in err.splitlines() if ln.strip()][-1]
        assert last.startswith("aborted (") and "heater at 0 V (0 V written and read back)" in last, err
        volts = server.accepted_volts()
        assert len(volts) > seen_before and volts[-1] == 0.0  # what the heater saw last: 0 V
        s = read_session(path)
        assert s.status is Status.ABORTED and s.n_samples >= 5, (run, s.events)
        assert [e.event for e in s.events].count("aborted") == 1
        assert "heater at 0 V" in s.events[-1].message


# ---------------------------------------------------------------- finding 2: reconnecting with integrity
@pytest.fixture(scope="module")
def reference(tmp_path_factory, shared_server):
    """The uninterrupted run every faulty run is compared with (the fast device is exact and noise-free)."""
    d = tmp_path_factory.mktemp("reference")
    path = d / "reference.h5"
    code, out, err = Child("--config", shared_server.client_config(d / "rig.toml"), *RUN, "--out", path).finish()
    assert code == 0, err
    return read_session(path)


def test_an_instrument_restarted_in_a_fresh_state_stops_the_run_and_resume_completes_it_right(tmp_path, reference):
    with SimServer(tmp_path, register_map=BOOT_MAP) as server:
        path = tmp_path / "run.h5"
        cfg = server.client_config(tmp_path / "rig.toml", retries=100)  # ~10 s of reconnection attempts (load)
        child = Child("--config", cfg, *RUN, "--out", path)
        wait_for_samples(path, 8, child=child)
        server.restart()  # killed, and a fresh device listens on the same port ~1 s later
        code, out, err = child.finish(timeout=60)
        s = read_session(path)
        # not one recorded sample comes from the fresh device: every one is what an uninterrupted run records
        np.testing.assert_array_equal(s.outputs, reference.outputs[: s.n_samples])
        line = one_line(err)
        assert code == 3 and s.status is Status.FAILED and s.n_samples < reference.n_samples, err
        assert "restarted" in line and "heater at 0 V (0 V written and read back)" in line
        assert f"rig acquire --resume {path}" in line
        assert "ContinuityError" in s.events[-1].message and "boot id" in s.events[-1].message
        assert server.accepted_volts()[-1] == 0.0  # the fresh device got the safe state last
        code, out, err = Child("--resume", path, "--json").finish(timeout=60)
        assert code == 0, err
        done = read_session(path)
        np.testing.assert_array_equal(done.inputs, reference.inputs)
        np.testing.assert_array_equal(done.outputs, reference.outputs)
        assert done.status is Status.COMPLETE and not np.any(done.samples["flags"] & SampleFlag.RECONNECTED)
        assert server.accepted_volts()[-1] == 0.0


def test_an_instrument_that_hangs_and_comes_back_is_checked_its_setpoint_resent_and_the_points_flagged(
        tmp_path, reference):
    with SimServer(tmp_path, register_map=BOOT_MAP) as server:
        path = tmp_path / "run.h5"
        cfg = server.client_config(tmp_path / "rig.toml", timeout=0.2, retries=40)
        child = Child("--config", cfg, *RUN, "--out", path)
        wait_for_samples(path, 8, child=child)
        server.stop()
        time.sleep(1.0)  # hung for 1 s: five timeouts of the client, which reconnects each time
        server.cont()
        code, out, err = child.finish(timeout=60)
        assert code == 0, err
        s = read_session(path)
        flagged = np.flatnonzero(s.samples["flags"] & SampleFlag.RECONNECTED)
        assert flagged.size >= 1, [e.event for e in s.events]
        assert f"{flagged.size} point(s) measured across a reconnection" in out
        # the instrument held its output and the beam its state: every sample is right, the flagged ones too
        np.testing.assert_array_equal(s.outputs, reference.outputs)
        assert s.status is Status.COMPLETE and [e.event for e in s.events].count("reconnected") == flagged.size
        # the set-point of the flagged point was sent again after the reconnection; the run ended at 0 V
        volts = server.accepted_volts()
        v = s.inputs[flagged[0]]
        assert any(a == b == np.float32(v) for a, b in zip(volts, volts[1:])) and volts[-1] == 0.0


# ---------------------------------------------------------------- finding 4: storage faults
@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs mounted for the test (root only; skipped with the reason elsewhere)."""
    if not sys.platform.startswith("linux") or os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("a small file system for the disk-full test needs root on Linux (mount -t tmpfs)")
    mnt = tmp_path / "disk"
    mnt.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m,mode=0755", "tmpfs", str(mnt)],
                          capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True, timeout=30)


def fill(disk: Path) -> Path:
    """Fill ``disk`` to the last byte (another program eating the space); returns the filler."""
    filler = disk / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    try:
        for block in (1 << 16, 1 << 12, 1):
            try:
                while os.write(fd, bytes(block)):
                    pass
            except OSError:
                pass
    finally:
        os.close(fd)
    return filler


#: A long run of quick points (the disk fills at the next 256-row chunk of /samples).
QUICK = ("--sequence", "random", "--points", 1500, "--dwell", 0.0, "--readings", 1)


def test_a_full_disk_stops_the_run_with_the_heater_at_0V_the_data_kept_and_failed_logged_once(
        tmp_path, small_disk, shared_server):
    path = small_disk / "run.h5"
    cfg = shared_server.client_config(tmp_path / "rig.toml")
    child = Child("--config", cfg, *QUICK, "--out", path)
    wait_for_samples(path, 10, child=child)
    filler = fill(small_disk)
    code, out, err = child.finish(timeout=60)
    line = one_line(err)
    assert code == 3, err  # not 139 (a segfault), not 1 (an internal error)
    assert "No space left on device" in line and "heater at 0 V (0 V written and read back)" in line
    assert shared_server.accepted_volts()[-1] == 0.0
    s = read_session(path)
    assert s.status is Status.FAILED and [e.event for e in s.events].count("failed") == 1
    assert s.n_samples >= 10 and np.array_equal(s.samples["index"], np.arange(s.n_samples))
    assert "StorageError" in s.events[-1].message
    # resuming while the disk is still full: one line, exit 3, nothing touched
    before = digest(path)
    code, out, err = Child("--resume", path).finish(timeout=60)
    line = one_line(err)
    assert code == 3 and "No space left on device" in line and "internal error" not in line, err
    assert digest(path) == before and sorted(p.name for p in small_disk.iterdir()) == ["filler", "run.h5"]
    # space again: the run is completed from where it stopped
    filler.unlink()
    code, out, err = Child("--resume", path, "--json").finish(timeout=60)
    assert code == 0, err
    done = read_session(path)
    assert done.status is Status.COMPLETE and done.n_samples == 1500
    np.testing.assert_array_equal(done.samples[: s.n_samples], s.samples)


def test_a_session_removed_during_the_run_stops_it_and_is_written_back(tmp_path, shared_server):
    path = tmp_path / "run.h5"
    child = Child("--config", shared_server.client_config(tmp_path / "rig.toml"), *RUN, "--out", path)
    wait_for_samples(path, 5, child=child)
    path.unlink()
    code, out, err = child.finish(timeout=60)
    line = one_line(err)
    assert code == 3 and "removed during the run" in line and "heater at 0 V (0 V written and read back)" in line
    assert shared_server.accepted_volts()[-1] == 0.0
    s = read_session(path)  # written back from the still-open file
    assert s.status is Status.FAILED and [e.event for e in s.events].count("failed") == 1
    assert s.n_samples >= 5 and np.array_equal(s.samples["index"], np.arange(s.n_samples))
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".h5") == ["run.h5"]


# ---------------------------------------------------------------- finding 6: one run per instrument
def test_a_second_run_on_the_same_instrument_is_refused_naming_the_holder(tmp_path, shared_server):
    server = shared_server
    cfg = server.client_config(tmp_path / "rig.toml")
    first, second = tmp_path / "first.h5", tmp_path / "second.h5"
    n0 = len(server.setpoints())
    a = Child("--config", cfg, *RUN, "--dwell", 0.5, "--out", first)  # slow enough to outlast the others
    wait_for_samples(first, 2, child=a)
    others = [Child("--config", cfg, *RUN, "--out", second),
              subprocess.Popen([rig_exe(), "selftest", "--config", str(cfg)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)]  # selftest would move the heater mid-run
    code, out, err = others[0].finish(timeout=60)
    line = one_line(err)
    assert code == 2 and "in use by another run" in line and f"pid {a.proc.pid}" in line, err
    assert f"127.0.0.1:{server.port}" in line and not second.exists()
    out, err = others[1].communicate(timeout=60)
    assert others[1].returncode == 2 and "in use by another run" in err, (out, err)
    assert a.proc.poll() is None, "the first run ended before the others were refused: nothing was tested"
    a.proc.send_signal(signal.SIGTERM)
    code, out, err = a.finish(timeout=60)
    assert code == 130, err
    # the heater saw the first run and nothing else: its opening 0 V, saturation, its points, the safe state
    s = read_session(first)
    seen = [e["volts"] for e in server.setpoints()[n0:]]
    planned = [float(np.float32(v)) for v in s.excitation.inputs]
    assert seen[:2] == [0.0, 0.0] and seen[-1] == 0.0 and seen[2:-1] == planned[: len(seen) - 3]
    assert len(seen) - 3 >= s.n_samples >= 2
