"""The fault-injection suite: ``rig acquire`` against ``rig serve-sim`` in real processes on loopback,
with faults injected from outside -- the server killed, hung (SIGSTOP) and continued, restarted in a
fresh state, bursts of signals, a full disk, a corrupted plan, two runs on one instrument.

Each test asserts three things: what the heater saw (the server's journal), what the session holds,
and what was printed.  Every wait is bounded (pytest-timeout, plus timeouts on every process)."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from sessions import Status, read_session

from .acquirekit import Child, wait_for_samples
from .faultkit import SimServer

pytestmark = pytest.mark.timeout(120)

#: L = 8 on [1, 6] V (no point of the plan is 0 V, so a 0 V in the journal can only be the safe state);
#: 0.1 s dwells on the fast device; one reading per measurement.
RUN = ("--levels", 8, "--v-min", 1.0, "--dwell", 0.1, "--readings", 1)


@pytest.fixture(scope="module")
def shared_server(tmp_path_factory):
    """One server for the tests that do not break it (each reads the journal entries after its own start)."""
    with SimServer(tmp_path_factory.mktemp("shared")) as server:
        yield server


def one_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
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


@pytest.mark.slow
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
