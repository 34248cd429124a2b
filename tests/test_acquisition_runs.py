"""The sequencer on the simulated device (in process, virtual clock): exactness, compressive plans,
pause/abort, driver faults and resuming with the memory state restored."""

import dataclasses

import numpy as np
import pytest

from drivers import SensorError, default_config, open_rig
from drivers.clock import VirtualClock
from identify import Grid
from rig.acquisition import (
    AcquisitionError,
    AcquisitionPlan,
    DwellSettings,
    FixedDwell,
    Hooks,
    PauseSwitch,
    Sequencer,
    Transit,
    acquire,
    make_record,
    resume,
    sequence_record,
    summarise,
)
from sessions import DataFileError, ExcitationRecord, SampleFlag, SessionWriter, Status, read_session

from .faultkit import sensor_dies_after

LEVELS = 8  # 38 points with the thermal point
#: 40 thermal time constants: the simulated device is exactly at rest (bit for bit).
SETTLED = DwellSettings(FixedDwell(20.0), Transit(0.0), readings=2)


def config(**sim):
    return default_config(levels=LEVELS, psd_noise_V=0.0, **sim)


def record(rig, measure=None, seed=0, sequence="damped", **kw):
    return make_record(sequence_record(sequence, rig.heater.window, levels=LEVELS, **kw), SETTLED, measure, seed)


class Snapshots:
    """on_sample hook: the device's state right after each point is recorded."""

    def __init__(self, rig):
        self.rig, self.states = rig, {}

    def __call__(self, result):
        self.states[result.index] = self.rig.device.state()


def run(path, measure=None, seed=0, hooks=None, **sim):
    with open_rig(config(**sim)) as rig:
        snap = Snapshots(rig)
        hooks = hooks or Hooks()
        hooks.on_sample = hooks.on_sample or snap
        outcome = acquire(rig, record(rig, measure, seed), path, hooks=hooks)
        assert rig.device.applied_voltage == 0.0
        return outcome, snap, read_session(path)


def fail_after(path, k, measure=None, **sim):
    """A run into ``path`` that a PSD fault stops at the first reading after point ``k`` is recorded;
    checks that it raised, left the heater at 0 V, and returns the number of points recorded."""
    with open_rig(config(**sim)) as rig:
        with pytest.raises(SensorError):
            acquire(rig, record(rig, measure, 3), path, hooks=sensor_dies_after(rig, k))
        assert rig.device.applied_voltage == 0.0
        assert rig.device.setpoints[-1][1] == 0.0
    return read_session(path).n_samples


def test_a_full_run_records_equation_22_exactly(tmp_path):
    outcome, snap, s = run(tmp_path / "full.h5")
    assert outcome.status is Status.COMPLETE and s.status is Status.COMPLETE
    truth = snap.rig.device.true_model()
    assert s.n_samples == 38 and np.array_equal(s.samples["index"], np.arange(38))
    np.testing.assert_allclose(s.outputs, truth.predict(s.inputs), rtol=0, atol=1e-12)
    assert np.all(s.samples["dwell_s"] == 20.0) and np.all(s.samples["settled"]) and np.all(s.measured)
    np.testing.assert_array_equal(s.t_s, 20.0 * np.arange(1, 39))
    assert s.samples["flags"][-1] == SampleFlag.REVERSAL | SampleFlag.THERMAL_POINT
    assert [e.event for e in s.events] == ["created", "saturated", "complete"]
    assert s.rig_config["sim"]["levels"] == LEVELS and s.driver["driver"] == "sim"
    assert s.excitation.dwell == SETTLED.describe()


def test_compressive_run_measures_exactly_the_planned_points_and_the_same_values(tmp_path):
    """Transit (0 s) at unmeasured non-reversal points, full dwell at reversals: every measured point
    sees the memory state of the full run, so its value is the same (the device has a 0.5 s thermal lag)."""
    _, _, full = run(tmp_path / "full.h5")
    outcome, snap, s = run(tmp_path / "cs.h5", measure=14, seed=3)
    plan = s.excitation.measure
    assert plan.sum() == 14 and np.array_equal(s.measured, plan)
    assert np.all(plan[AcquisitionPlan.from_record(s.excitation).reversals])
    assert np.all(np.isnan(s.samples["output"][~plan])) and np.all(s.samples["dwell_s"][~plan] == 0.0)
    assert not s.samples["settled"][~plan].any()
    np.testing.assert_allclose(s.outputs[plan], full.outputs[plan], rtol=0, atol=1e-12)
    summary = summarise(s, outcome)
    assert (summary["n_measured"], summary["n_planned_measured"], summary["n_applied"]) == (14, 14, 38)
    # exactly (38 - 14) points x 20 s were saved: the full run's rig time
    assert summary["rig_time_s"] == 14 * 20.0
    assert summary["full_time_s"] == full.t_s[-1] == 38 * 20.0


def test_unsettled_reversal_points_would_corrupt_the_memory_state(tmp_path):
    """The counter-check: the same plan with a transit at the reversal points measures wrong values."""
    _, _, full = run(tmp_path / "full.h5")
    with open_rig(config()) as rig:
        rec = record(rig, measure=14, seed=3)
        plan = AcquisitionPlan.from_record(rec)
        careless = dataclasses.replace(plan, reversals=np.zeros_like(plan.reversals))
        careless_rec = dataclasses.replace(rec, measure=rec.measure & ~plan.reversals)
        careless = dataclasses.replace(careless, record=careless_rec)
        with SessionWriter.create(tmp_path / "careless.h5", careless_rec) as w:
            Sequencer(rig.heater, rig.sensor, rig.clock, careless, SETTLED, w).run()
    s = read_session(tmp_path / "careless.h5")
    m = s.measured
    assert np.abs(s.outputs[m] - full.outputs[m]).max() > 0.1  # um


def test_a_driver_fault_mid_run_leaves_heater_off_status_failed_and_data_kept(tmp_path):
    path = tmp_path / "fault.h5"
    assert fail_after(path, 20) == 21
    s = read_session(path)
    assert s.status is Status.FAILED and s.n_samples == 21 and not s.writer_alive()
    assert "SensorError" in s.events[-1].message


def interrupted_then_resumed(tmp_path, at, measure=None, **sim):
    """Fail a run at point ``at`` (a sensor fault), then resume it on a fresh rig (a new process would
    see the same: opening the rig writes 0 V).  The fault hits at the next reading, so the run stops
    at the first measured point from ``at`` on.  Returns the resumed session, outcome, snapshots and
    the number of points recorded before the resume."""
    path = tmp_path / "resumed.h5"
    cut = fail_after(path, at - 1, measure, **sim)
    plan = read_session(path).excitation.measure
    assert cut == at + int(np.argmax(plan[at:]))
    with open_rig(config(**sim)) as rig:
        snap = Snapshots(rig)
        outcome = resume(rig, path, hooks=Hooks(on_sample=snap))
    return read_session(path), outcome, snap, cut


@pytest.mark.parametrize("at, measure", [(1, None), (17, None), (23, 14), (36, 14)])
def test_resume_restores_the_memory_state_and_completes_like_an_uninterrupted_run(tmp_path, at, measure):
    _, ref, full = run(tmp_path / "ref.h5", measure=measure, seed=3)
    s, outcome, snap, at = interrupted_then_resumed(tmp_path, at, measure)
    assert outcome.status is Status.COMPLETE and outcome.start == at and outcome.replayed == at
    assert s.status is Status.COMPLETE and s.n_samples == 38
    assert np.array_equal(s.samples["index"], np.arange(38))  # nothing duplicated, nothing skipped
    np.testing.assert_array_equal(s.inputs, full.inputs)
    np.testing.assert_array_equal(s.measured, full.measured)
    np.testing.assert_allclose(s.outputs[s.measured], full.outputs[full.measured], rtol=0, atol=1e-12)
    # the device is in the same state after every resumed point, and at the end
    for k in range(at, 38):
        a, b = snap.states[k], ref.states[k]
        assert a.memory == b.memory, k
        np.testing.assert_array_equal(a.signed_areas, b.signed_areas)
        assert (a.temperature_C, a.voltage_V, a.deflection_um) == (b.temperature_C, b.voltage_V, b.deflection_um)
    flags = s.samples["flags"]
    assert np.flatnonzero(flags & SampleFlag.AFTER_RESUME).tolist() == [at]
    np.testing.assert_array_equal(s.t_s, full.t_s)  # run time goes on across the resume, as if never cut
    events = [e.event for e in s.events]
    assert events == ["created", "saturated", "failed", "reopened", "saturated", "replayed", "complete"]


def test_resume_without_replay_would_be_wrong(tmp_path):
    """The counter-check: continuing from the state the rig opens in (0 V) gives other values."""
    _, _, full = run(tmp_path / "ref.h5")
    path = tmp_path / "naive.h5"
    assert fail_after(path, 16) == 17
    with open_rig(config()) as rig, SessionWriter.reopen(path) as w:
        plan = AcquisitionPlan.from_record(read_session(path).excitation)
        Sequencer(rig.heater, rig.sensor, rig.clock, plan, SETTLED, w).run(start=w.count)
    s = read_session(path)
    assert np.abs(s.outputs[17:] - full.outputs[17:]).max() > 0.1


def test_resume_refuses_complete_and_foreign_sessions(tmp_path):
    _, _, s = run(tmp_path / "done.h5")
    with open_rig(config()) as rig:
        with pytest.raises(DataFileError, match="complete; there is nothing to resume"):
            resume(rig, s.path)
    rec = ExcitationRecord("imported", np.array([1.0, 2.0]), dwell={"policy": "unknown"})
    w = SessionWriter.create(tmp_path / "foreign.h5", rec)
    w.append(0.0, 1.0, 2.0)
    w.finish(Status.ABORTED)
    with open_rig(config()) as rig:
        with pytest.raises(AcquisitionError, match="not recorded by 'rig acquire'"):
            resume(rig, tmp_path / "foreign.h5")


def test_a_plan_outside_the_heater_window_is_refused_before_anything_happens(tmp_path):
    with open_rig(config()) as rig:
        rec = make_record(sequence_record("damped", rig.heater.window, levels=4, v_max=7.0), SETTLED)
        with pytest.raises(AcquisitionError, match="outside the heater's window"):
            acquire(rig, rec, tmp_path / "x.h5")
        assert list(rig.device.setpoints) == [(0.0, 0.0)]  # only the 0 V of opening the rig
    assert not (tmp_path / "x.h5").exists()


class PausingClock(VirtualClock):
    """A virtual clock that presses Ctrl-C (requests a pause) once it reaches a given time."""

    def __init__(self, switch, at_s):
        super().__init__()
        self.switch, self.at_s = switch, at_s

    def sleep(self, seconds):
        super().sleep(seconds)
        if self.at_s is not None and self.now() >= self.at_s:
            self.at_s = None
            self.switch.request()


@pytest.mark.parametrize("decision", ["resume", "abort"])
def test_a_pause_during_a_dwell_holds_the_heater_then_resumes_or_aborts(tmp_path, decision):
    switch = PauseSwitch()
    # saturation and 5 points, then 0.1 s into point 5, within the first slice of its wait (a virtual
    # clock is only sliced once: then the sequencer sees it is not real time)
    clock = PausingClock(switch, at_s=20.0 + 5 * 20.0 + 0.1)
    seen = []

    def on_pause(info):
        seen.append((info, rig.device.applied_voltage, rig.device.state().memory))
        clock.sleep(600.0)  # the operator takes ten minutes to decide; the heater stays on
        seen.append(rig.device.applied_voltage)
        return decision

    path = tmp_path / "p.h5"
    with open_rig(config(), clock=clock) as rig:
        outcome = acquire(rig, record(rig), path, hooks=Hooks(switch, on_pause))
        assert rig.device.applied_voltage == 0.0
    info, volts, _ = seen[0]
    assert (info.index, info.phase) == (5, "dwell") and volts == info.setpoint_V == seen[1] != 0.0
    s = read_session(path)
    events = [e.event for e in s.events]
    if decision == "resume":
        assert outcome.status is Status.COMPLETE and s.n_samples == 38
        assert events == ["created", "saturated", "paused", "continued", "complete"]
        assert s.samples["dwell_s"][5] == 620.25  # the dwell restarts after the pause: a slice + 600 + 20 s
        _, _, full = run(tmp_path / "ref.h5")
        np.testing.assert_allclose(s.outputs, full.outputs, rtol=0, atol=1e-12)
    else:
        assert outcome.status is Status.ABORTED and s.status is Status.ABORTED and s.n_samples == 5
        assert events == ["created", "saturated", "paused", "aborted"]
        assert "aborted by the operator at point 5" in s.events[-1].message


def test_without_a_pause_switch_ctrl_c_aborts_at_once_and_keeps_the_samples(tmp_path):
    path = tmp_path / "k.h5"
    with open_rig(config()) as rig:
        def press(result):
            if result.index == 9:
                raise KeyboardInterrupt

        outcome = acquire(rig, record(rig), path, hooks=Hooks(on_sample=press))
        assert rig.device.applied_voltage == 0.0
    s = read_session(path)
    assert outcome.status is Status.ABORTED and s.status is Status.ABORTED and s.n_samples == 10


def test_resume_keeps_a_per_point_dwell_schedule(tmp_path):
    """A check run's several dwells survive an interruption: the resumed points wait as planned."""
    grid = Grid(LEVELS, 0.0, 6.0)
    v = np.array([1.0, 3.0, 2.0, 2.0, 5.0, 0.5, 4.0])
    dwell = (8.0, 30.0, 15.0, 60.0, 8.0, 30.0, 15.0)
    settings = DwellSettings(FixedDwell(20.0), Transit(0.0), 2, dwell)
    record = make_record(ExcitationRecord(kind="check", inputs=v, levels=grid.levels, v_min=grid.v_min,
                                          v_max=grid.v_max), settings)
    ref = tmp_path / "ref.h5"
    with open_rig(config()) as rig:
        acquire(rig, record, ref)
    path = tmp_path / "cut.h5"
    with open_rig(config()) as rig:
        with pytest.raises(SensorError):
            acquire(rig, record, path, hooks=sensor_dies_after(rig, 2))
    with open_rig(config()) as rig:
        resume(rig, path)
    a, b = read_session(ref), read_session(path)
    np.testing.assert_allclose(b.samples["dwell_s"], dwell, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(a.t_s, b.t_s)
    np.testing.assert_allclose(a.outputs, b.outputs, rtol=0, atol=1e-12)
    with pytest.raises(AcquisitionError, match="3 per-point dwell times for a plan of 7 points"):
        make_record(record, DwellSettings(FixedDwell(20.0), schedule=(1.0, 2.0, 3.0)))


@pytest.mark.parametrize("fault", ["nan_readings", "saturated_readings"])
def test_a_reading_retried_after_nan_or_saturated_values_flags_its_point(tmp_path, fault):
    """Issue 28, item 4: READ_RETRIED (bit 32) is set wherever a reading was retried, and nowhere else."""
    def inject(result):
        if result.index == 5:
            setattr(rig.device.faults, fault, 2)  # point 6's first two readings; the third is good

    with open_rig(config()) as rig:
        acquire(rig, record(rig), tmp_path / "s.h5", hooks=Hooks(on_sample=inject))
    s = read_session(tmp_path / "s.h5")
    assert s.status is Status.COMPLETE
    assert np.flatnonzero(s.samples["flags"] & SampleFlag.READ_RETRIED).tolist() == [6]
