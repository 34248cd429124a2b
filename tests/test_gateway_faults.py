"""No silent bad sample (issue 28): ``rig acquire`` against ``rig serve-sim`` through a misbehaving Modbus
gateway (:mod:`tests.modbusproxy`, a real asyncio proxy on loopback).

Every reply that does not answer its request (wrong function code, byte count, unit, transaction), every
NaN or saturated value, every late or cut reply is retried and the point flagged ``READ_RETRIED``, with
the same samples as an uninterrupted run; a stale or frozen PSD is read again, and stops the run when it
persists; a set-point the instrument acknowledges but never applies stops the run before anything is
measured against it.  Each test asserts what the session holds and what was printed; every process and
wait is bounded."""

from __future__ import annotations

import numpy as np
import pytest

from rig.testing import Child
from sessions import SampleFlag, Status, read_session

from .faultkit import FAST_SIM, SimServer
from .modbusproxy import Fault, ModbusProxy
from .test_faults import one_line, shared_server  # noqa: F401  (shared_server is a fixture)

pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]

#: L = 8 on [1, 6] V (38 points), 0.05 s dwells on the fast device (at rest to the last float32 bit), K = 1.
RUN = ("--levels", 8, "--v-min", 1.0, "--dwell", 0.05, "--readings", 1)


@pytest.fixture(scope="module")
def server(shared_server):
    return shared_server


@pytest.fixture(scope="module")
def reference(tmp_path_factory, server):
    d = tmp_path_factory.mktemp("reference")
    (d / "rig.toml").write_text(server.client_toml())
    code, out, err = Child("--config", d / "rig.toml", *RUN, "--out", d / "ref.h5").finish()
    assert code == 0, err
    return read_session(d / "ref.h5")


def through(tmp_path, server, faults, *args, retries=3, name="run.h5"):
    """``rig acquire`` through a proxy committing ``faults``; returns (exit code, stdout, stderr, session)."""
    with ModbusProxy(server.port, faults) as proxy:
        cfg = tmp_path / "proxy.toml"
        cfg.write_text(server.client_toml(retries=retries, port=proxy.port))
        code, out, err = Child("--config", cfg, *(args or RUN), "--out", tmp_path / name).finish(timeout=90)
    assert all(f.applied for f in faults), "the gateway never misbehaved: nothing was tested"
    return code, out, err, read_session(tmp_path / name)


def retried_rows(s) -> list[int]:
    return np.flatnonzero(s.samples["flags"] & SampleFlag.READ_RETRIED).tolist()


# ---------------------------------------------------------------- items 1 and 4: retried and flagged
#: PSD read 5 is point 4's (read 0 is the saturation's).
BAD_REPLIES = {
    "wrong_function": Fault("wrong_function"),  # an FC 3 frame answering an FC 4 read, 20 um off
    "byte_count": Fault("byte_count"),  # byte count 4 over six data bytes
    "wrong_unit": Fault("wrong_unit"),
    "wrong_tid": Fault("wrong_tid"),
    "nan": Fault("nan", count=2),  # two NaN then a good one
    "saturated": Fault("saturated", count=2),  # two at the rail then a good one
    "slow": Fault("slow", value=0.5),  # later than the 0.3 s timeout
    "truncated": Fault("truncated"),  # half a frame
    "stale": Fault("stale"),  # point 3's reply again, at point 4
}


@pytest.mark.parametrize("mode", list(BAD_REPLIES))
def test_a_bad_reply_is_retried_and_the_point_flagged_with_the_right_sample(tmp_path, server, reference, mode):
    fault = Fault(**{**BAD_REPLIES[mode].__dict__, "after": 5, "seen": 0, "applied": 0})
    code, out, err, s = through(tmp_path, server, [fault])
    assert code == 0 and "Traceback" not in err, err
    assert s.status is Status.COMPLETE
    np.testing.assert_array_equal(s.outputs, reference.outputs)  # not one wrong sample
    assert retried_rows(s) == [4], s.samples["flags"]
    assert "1 point(s) needed a repeated reading" in out


def test_a_gateway_that_keeps_answering_with_the_wrong_function_code_stops_the_run(tmp_path, server, reference):
    code, out, err, s = through(tmp_path, server, [Fault("wrong_function", after=5, count=None)])
    line = one_line(err)
    assert code == 3 and s.status is Status.FAILED, err
    assert "function code 3 to a request with function code 4" in line
    assert "heater at 0 V (0 V written and read back)" in line
    np.testing.assert_array_equal(s.outputs, reference.outputs[: s.n_samples])
    assert s.n_samples == 4


# ---------------------------------------------------------------- item 2: stale and stuck
def test_a_psd_frozen_at_a_constant_stops_the_run_naming_it(tmp_path, server, reference):
    code, out, err, s = through(tmp_path, server, [Fault("constant", after=20, count=None, value=0.5)])
    line = one_line(err)
    assert code == 3 and s.status is Status.FAILED, err
    assert "stale or frozen" in line and "0.5 V" in line
    # with one reading per point the first frozen value cannot be told from a measurement (point 19);
    # nothing after it is recorded
    assert s.n_samples == 20
    np.testing.assert_array_equal(s.outputs[:19], reference.outputs[:19])


def test_a_noisy_psd_that_gets_stuck_is_caught_within_the_point(tmp_path):
    noisy = FAST_SIM.replace("psd_noise_V = 0.0", "psd_noise_V = 0.002")
    with SimServer(tmp_path, name="noisy", sim=noisy) as server:
        # K = 4: the saturation's 4 readings, then 4 per point; read 84 is point 20's first
        code, out, err, s = through(tmp_path, server, [Fault("constant", after=84, count=None, value=0.5)],
                                    *RUN[:-1], 4)
    line = one_line(err)
    assert code == 3 and s.status is Status.FAILED, err
    assert "stuck sensor" in line
    assert s.n_samples == 20 and not np.any(s.samples["raw"] == np.float32(0.5))


# ---------------------------------------------------------------- item 3: acknowledged but not applied
def test_a_setpoint_acknowledged_but_never_applied_stops_the_run_before_a_wrong_sample(tmp_path, server, reference):
    # write 0 is the opening 0 V, 1 the saturation, then one per point: point 8's write and all after are lost
    code, out, err, s = through(tmp_path, server, [Fault("drop_write", "write", after=10, count=None)])
    line = one_line(err)
    assert code == 3 and s.status is Status.FAILED, err
    assert s.n_samples == 8
    np.testing.assert_array_equal(s.outputs, reference.outputs[:8])  # every sample against its real voltage
    held = f"{np.float32(reference.inputs[7]):g} V"
    assert line.startswith(f"Error: the heater reads back {held} at point 8"), line
    # the closing words lead with what is known: the output reads back the old set-point, not "may be at 0 V"
    assert f"heater NOT at 0 V: it reads back {held}" in line and "may still be at 0 V" not in line
    assert "heater NOT at 0 V" in s.events[-1].message
