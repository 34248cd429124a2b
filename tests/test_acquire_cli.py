"""``rig acquire`` as operators and scripts use it: real processes, real signals, a simulated bench
served over Modbus TCP on loopback (so the heater is checked at the server)."""

import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from rig.testing import Child, served
from sessions import SampleFlag, Status, read_session

from .acquirekit import FAST_DEVICE, SetpointSpy, Terminal, bench_config, wait_for_samples
from .cli import assert_one_line_error, rig_here
from .conftest import digest

#: L = 8: 38 points; 0.1 s dwell on the fast device; one reading per measurement.
RUN = ("--levels", 8, "--dwell", 0.1, "--readings", 1)


@pytest.mark.slow
def test_sigkill_mid_run_keeps_what_was_reported_and_resume_ends_like_an_uninterrupted_run(tmp_path):
    with served(modbus=True, **FAST_DEVICE) as bench_a, served(modbus=True, **FAST_DEVICE) as bench_b:
        spy_a, spy_b = SetpointSpy(bench_a.device), SetpointSpy(bench_b.device)
        full, cut = tmp_path / "full.h5", tmp_path / "cut.h5"
        # the uninterrupted reference, compressive: 12 of 38 points measured
        ref = Child("--config", bench_config(bench_a, tmp_path, "a.toml"), *RUN, "--measure", 12, "--out", full,
                    "--json")
        code, out, err = ref.finish()
        assert code == 0, err
        assert json.loads(out)["status"] == "complete"
        # the same run, killed in the middle
        child = Child("--config", bench_config(bench_b, tmp_path, "b.toml"), *RUN, "--measure", 12, "--out", cut,
                      "--progress")
        wait_for_samples(cut, 15, child=child)
        os.kill(child.proc.pid, signal.SIGKILL)
        code, _, _ = child.finish()
        assert code == -signal.SIGKILL
        before = digest(cut)
        s = read_session(cut)
        assert digest(cut) == before  # reading never writes
        assert s.status is Status.RUNNING and not s.writer_alive()
        assert 15 <= s.n_samples < 38 and s.n_samples >= child.reported() > 0
        assert np.array_equal(s.samples["index"], np.arange(s.n_samples))
        cut_at = s.n_samples
        # resume: no --config, the session's stored configuration points at bench B
        code, out, err = Child("--resume", cut, "--json").finish()
        assert code == 0, err
        summary = json.loads(out)
        assert (summary["status"], summary["resumed"], summary["n_replayed"]) == ("complete", True, cut_at)
        a, b = read_session(full), read_session(cut)
        assert b.n_samples == 38 and np.array_equal(b.samples["index"], np.arange(38))
        np.testing.assert_array_equal(b.inputs, a.inputs)
        np.testing.assert_array_equal(b.measured, a.measured)
        np.testing.assert_array_equal(b.outputs[b.measured], a.outputs[a.measured])
        assert np.flatnonzero(b.samples["flags"] & SampleFlag.AFTER_RESUME).tolist() == [cut_at]
        assert [e.event for e in b.events] == ["created", "saturated", "reopened", "saturated", "replayed",
                                               "complete"]
        # the simulated device ends in the same state as after the uninterrupted run
        end_a, end_b = spy_a.state_at_end(), spy_b.state_at_end()
        assert end_b.memory == end_a.memory
        np.testing.assert_array_equal(end_b.signed_areas, end_a.signed_areas)
        assert (end_b.voltage_V, end_b.temperature_C) == (end_a.voltage_V, end_a.temperature_C)
        assert bench_a.device.applied_voltage == bench_b.device.applied_voltage == 0.0


@pytest.mark.slow
def test_a_driver_fault_mid_run_exits_3_with_heater_off_status_failed_and_data_kept(tmp_path):
    with served(modbus=True, **FAST_DEVICE) as bench:
        path = tmp_path / "fault.h5"
        cfg = bench_config(bench, tmp_path)
        child = Child("--config", cfg, *RUN, "--out", path)
        wait_for_samples(path, 6, child=child)
        bench.faults.nan_readings = 10_000
        code, out, err = child.finish()
        assert code == 3, err
        lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("plan: ")]  # the plan, then
        assert len(lines) == 1 and "Traceback" not in err                                       # one error line
        assert "no usable deflection reading" in lines[0] and f"rig acquire --resume {path}" in lines[0]
        assert bench.device.applied_voltage == 0.0
        assert bench.journal.setpoints[-1].volts == 0.0
        s = read_session(path)
        assert s.status is Status.FAILED and 6 <= s.n_samples < 38
        assert np.all(np.isfinite(s.outputs)) and "SensorError" in s.events[-1].message
        # the bench is healthy again: the session is completed where it stopped
        bench.faults.nan_readings = 0
        code, out, err = Child("--resume", path, "--json").finish()
        assert code == 0, err
        s2 = read_session(path)
        assert s2.status is Status.COMPLETE and s2.n_samples == 38
        np.testing.assert_array_equal(s2.samples[: s.n_samples], s.samples)


def paused_run(tmp_path, bench, term, sig=signal.SIGINT):
    """A run interrupted by ``sig`` after 5 samples; with a terminal, waits for the pause prompt."""
    path = tmp_path / "pause.h5"
    child = Child("--config", bench_config(bench, tmp_path), "--levels", 8, "--dwell", 0.05, "--readings", 1,
                  "--out", path, stdin=term.slave if term else subprocess.DEVNULL)
    wait_for_samples(path, 5, child=child)
    os.kill(child.proc.pid, sig)
    if term is not None:
        child.wait_for("[r]esume or [a]bort?")
    return path, child


def answered(tmp_path, bench, answer):
    """A run paused by Ctrl-C on a terminal; ``answer(path, child, term)`` acts at the prompt.  Returns the
    session path and the child's exit code, stdout and stderr."""
    term = Terminal()
    try:
        path, child = paused_run(tmp_path, bench, term)
        answer(path, child, term)
        return (path, *child.finish())
    finally:
        term.close()


@pytest.mark.slow
def test_ctrl_c_pauses_with_the_heater_held_then_resumes(tmp_path):
    with served(modbus=True, **FAST_DEVICE) as bench:
        def check_then_resume(path, child, term):
            held = bench.device.applied_voltage
            n = read_session(path).n_samples
            time.sleep(0.5)  # paused: nothing moves
            s = read_session(path)
            assert s.n_samples == n and s.status is Status.RUNNING and s.events[-1].event == "paused"
            assert bench.device.applied_voltage == held
            assert held in (s.inputs[-1], s.excitation.inputs[n])  # the point before, or the one it waits at
            # a paused run is still a live writer: nobody else may continue it
            assert_one_line_error(rig_here("acquire", "--resume", path), "another process is writing")
            term.type("r\n")

        path, code, out, err = answered(tmp_path, bench, check_then_resume)
        assert code == 0, err
        s = read_session(path)
        assert s.status is Status.COMPLETE and s.n_samples == 38
        assert np.array_equal(s.samples["index"], np.arange(38))
        assert [e.event for e in s.events] == ["created", "saturated", "paused", "continued", "complete"]
        assert bench.device.applied_voltage == 0.0


@pytest.mark.slow
def test_ctrl_c_twice_aborts_with_the_heater_off_and_samples_kept(tmp_path):
    with served(modbus=True, **FAST_DEVICE) as bench:
        def press_again(path, child, term):
            os.kill(child.proc.pid, signal.SIGINT)

        path, code, out, err = answered(tmp_path, bench, press_again)
        assert code == 130, err
        assert bench.device.applied_voltage == 0.0
        s = read_session(path)
        assert s.status is Status.ABORTED and 5 <= s.n_samples < 38
        assert [e.event for e in s.events] == ["created", "saturated", "paused", "aborted"]
        assert "aborted" in out and f"rig acquire --resume {path}" in err


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_without_a_terminal_or_sigterm_stops_the_run(tmp_path, sig):
    with served(modbus=True, **FAST_DEVICE) as bench:
        path, child = paused_run(tmp_path, bench, None, sig)
        code, out, err = child.finish()
        assert code == 130, err
        assert bench.device.applied_voltage == 0.0
        s = read_session(path)
        assert s.status is Status.ABORTED and 5 <= s.n_samples < 38
        if sig == signal.SIGINT:  # a pause nobody can answer: stop at the safe point
            assert "no terminal to ask" in err
            assert [e.event for e in s.events][-2:] == ["paused", "aborted"]
        else:  # SIGTERM: abort now (appends and instrument transactions still finish first)
            assert [e.event for e in s.events][-2:] == ["saturated", "aborted"]


# ---------------------------------------------------------------- in process: output and errors
def test_default_run_on_the_simulated_device_and_its_summary(tmp_path):
    path = tmp_path / "s.h5"
    run = rig_here("acquire", "--levels", 8, "--measure", 20, "--seed", 4, "--out", path, "--json")
    assert run.code == 0, run.err
    summary = json.loads(run.out)
    assert summary["session"] == str(path) and summary["status"] == "complete"
    assert (summary["excitation"], summary["levels"], summary["v_min"], summary["v_max"]) == ("damped", 8, 0.0, 6.0)
    assert (summary["n_points"], summary["n_applied"], summary["n_measured"], summary["n_reversals"]) == (38, 38, 20, 9)
    assert summary["clock"] == "virtual" and summary["n_timeouts"] == 0 and not summary["resumed"]
    # fixed 20 s dwell: 18 points not measured saved 18 x 20 s of the 38 x 20 s
    assert (summary["rig_time_s"], summary["full_time_s"], summary["time_saved_s"]) == (400.0, 760.0, 360.0)
    s = read_session(path)
    assert np.array_equal(s.measured, s.excitation.measure) and s.measured.sum() == 20
    text = rig_here("acquire", "--levels", 8, "--measure", 20, "--out", tmp_path / "t.h5")
    assert "saved 0:06:00 (47%)" in text.out and "20 measured (9 reversal points)" in text.out


def test_settle_policy_and_a_file_of_setpoints(tmp_path):
    f = tmp_path / "sp.csv"
    f.write_text("v_V\n" + "\n".join(str(x) for x in [1.0, 4.0, 2.0, 5.5, 0.5, 3.0]) + "\n")
    run = rig_here("acquire", "--sequence", f, "--settle", 0.05, "--dwell", 30, "--out", tmp_path / "f.h5", "--json")
    assert run.code == 0, run.err
    s = read_session(tmp_path / "f.h5")
    assert s.excitation.kind == "file" and s.inputs.tolist() == [1.0, 4.0, 2.0, 5.5, 0.5, 3.0]
    assert s.excitation.dwell["policy"] == "settle" and np.all(s.samples["settled"])
    assert np.all(s.samples["dwell_s"] < 30) and np.all(s.samples["dwell_s"] >= 1.0)  # two polls at least


@pytest.mark.parametrize("args, fragments", [
    (["--levels", 8], ["--out"]),
    (["--levels", 8, "--measure", 5, "--out", "{d}/x.h5"], ["fewer than the 9 reversal points"]),
    (["--levels", 8, "--v-max", 7, "--out", "{d}/x.h5"], ["outside the heater's window"]),
    (["--levels", 8, "--dwell", -1, "--out", "{d}/x.h5"], ["dwell"]),
    (["--levels", 8, "--readings", 0, "--out", "{d}/x.h5"], ["readings"]),
    (["--sequence", "{d}/none.csv", "--out", "{d}/x.h5"], ["no such file"]),
    (["--config", "{d}/none.toml", "--out", "{d}/x.h5"], ["no such file"]),
    (["--resume", "{d}/done.h5", "--levels", 8], ["--levels cannot be used with it"]),
    (["--resume", "{d}/done.h5"], ["complete; there is nothing to resume"]),
    (["--out", "{d}/done.h5", "--levels", 8], ["already exists"]),
])
def test_bad_requests_are_one_line_errors_and_touch_nothing(tmp_path, args, fragments):
    done = tmp_path / "done.h5"
    assert rig_here("acquire", "--levels", 2, "--out", done).code == 0
    before = digest(done)
    run = rig_here("acquire", *[str(a).format(d=tmp_path) for a in args])
    assert_one_line_error(run, *fragments)
    assert digest(done) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done.h5"]


def test_a_dwell_column_gives_every_point_its_own_dwell(tmp_path):
    f = tmp_path / "check.csv"
    v, dwell = [1.0, 4.0, 4.0, 2.0, 5.5, 0.5], [8.0, 15.0, 60.0, 8.0, 30.0, 15.0]
    f.write_text("v_V,dwell_s\n" + "\n".join(f"{a},{b}" for a, b in zip(v, dwell)) + "\n")
    run = rig_here("acquire", "--sequence", f, "--dwell", 20, "--out", tmp_path / "c.h5", "--json")
    assert run.code == 0, run.err
    s = read_session(tmp_path / "c.h5")
    assert s.inputs.tolist() == v
    np.testing.assert_allclose(s.samples["dwell_s"], dwell, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.diff(s.t_s), dwell[1:], rtol=0, atol=1e-9)
    assert s.excitation.dwell["schedule_s"] == dwell and s.excitation.dwell["seconds"] == 20.0


@pytest.mark.parametrize("text, extra, fragments", [
    ("v_V,dwell_s\n1.0,5\n2.0,-1\n", [], ["line 3", "dwell_s", "negative"]),
    ("v_V,dwell_s\n1.0,5\n2.0,x\n", [], ["line 3", "not a number"]),
    ("v_V,dwell_s\n1.0,5\n2.0,7\n", ["--settle", 0.05], ["cannot be combined with --settle"]),
])
def test_bad_dwell_columns_are_one_line_errors(tmp_path, text, extra, fragments):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    run = rig_here("acquire", "--sequence", f, *extra, "--out", tmp_path / "x.h5")
    assert_one_line_error(run, *fragments)
    assert not (tmp_path / "x.h5").exists()


def test_a_check_sequence_for_the_gap_diagnosis(tmp_path):
    run = rig_here("acquire", "--sequence", "check", "--points", 40, "--seed", 5, "--out", tmp_path / "v.h5")
    assert run.code == 0, run.err
    s = read_session(tmp_path / "v.h5")
    assert s.excitation.kind == "check" and s.n_samples == 40 and s.grid.levels == 30
    dwell = s.samples["dwell_s"]
    assert set(np.round(dwell, 6)) <= {8.0, 15.0, 30.0, 60.0} and len(set(np.round(dwell, 6))) > 1
    assert s.excitation.dwell["schedule_s"] == list(dwell)
    assert np.any(np.diff(s.inputs) == 0)  # repeated set-points
    again = rig_here("acquire", "--sequence", "check", "--points", 40, "--seed", 5, "--out", tmp_path / "w.h5")
    assert again.code == 0 and np.array_equal(read_session(tmp_path / "w.h5").inputs, s.inputs)
