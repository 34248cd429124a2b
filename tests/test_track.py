"""rig invert and rig track: set-points offline, tracking on the rig (the simulated device in process, and
rig serve-sim over Modbus), resuming a tracking run, and bad input refused before anything is applied."""

import dataclasses
import json
import math

import numpy as np
import pytest

from drivers import SensorError, default_config, open_rig
from drivers.clock import VirtualClock
from drivers.sim import SimParams, SimVO2
from identify import Grid, PreisachModel
from identify.model_json import model_from_dict, model_to_dict
from rig.acquisition import acquire, resume
from rig.tracking.run import plan_track, setpoints_for
from rig.tracking.source import load_source
from sessions import TRACKING_COLUMNS, Status, read_session
from sessions.targets import Targets, read_targets, write_targets

from .cli import assert_one_line_error, rig_here
from .faultkit import SimServer, sensor_dies_after

#: The rms noise of one recorded measurement on the default simulated device (2 mV x 5 um/V / sqrt(4)).
SIGMA = 0.005


def true_model(tmp_path, name="model.json", **sim):
    """The built-in simulated device's own model (equation (22) exactly), as a model JSON file."""
    model = SimVO2(SimParams(**sim), VirtualClock()).true_model()
    path = tmp_path / name
    path.write_text(json.dumps(model_to_dict(model)))
    return path, model


def targets_file(tmp_path, y, step=20.0, name="target.csv"):
    path = tmp_path / name
    write_targets(path, Targets(step * np.arange(1, len(y) + 1), np.asarray(y, dtype=float)))
    return path


def sines(n=40, repeats=1):
    k = np.arange(n)
    return np.tile(-2.5 + 9.5 * np.cos(2 * np.pi * k / 10) * np.exp(-k / n * 2), repeats)


# ---------------------------------------------------------------- rig invert
def test_rig_invert_writes_set_points_that_the_model_maps_onto_the_targets(tmp_path):
    model_path, model = true_model(tmp_path)
    y = sines()
    out = tmp_path / "v.csv"
    r = rig_here("invert", model_path, targets_file(tmp_path, y), "--out", out, "--json")
    assert r.code == 0, r.err
    res = r.json()
    assert res["n"] == 40 and res["unreachable"] == 0 and res["model"] == "model"
    lines = out.read_text().splitlines()
    assert lines[0] == "t_s,v_V,target_um,predicted_um,reachable"
    table = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    np.testing.assert_allclose(table[:, 2], y)
    np.testing.assert_allclose(model.predict(table[:, 1]), y, rtol=0, atol=1e-9)  # forward(inverse(y)) = y
    np.testing.assert_allclose(table[:, 3], y, rtol=0, atol=1e-9)
    assert np.all(table[:, 4] == 1)
    # a target out of reach from the memory state is reported, with the closest output: one triangular cell
    # on [0, 1] V, u = 2 v^2 - v - 1 rising from 0 V; from the top (0 um at 1 V) the way down ends at -1 um (0 V)
    cell = PreisachModel(Grid(1, 0.0, 1.0), np.array([1.0]), 0.0, -1.0)
    (tmp_path / "cell.json").write_text(json.dumps(model_to_dict(cell)))
    r = rig_here("invert", tmp_path / "cell.json", targets_file(tmp_path, [0.0, -1.12], name="t2.csv"), "--out",
                 tmp_path / "v2.csv", "--json")
    assert r.code == 0, r.err
    assert r.json()["unreachable"] == 1
    rows = [[float(x) for x in ln.split(",")] for ln in (tmp_path / "v2.csv").read_text().splitlines()[1:]]
    assert rows[0][1:] == pytest.approx([1.0, 0.0, 0.0, 1.0], abs=1e-12)
    assert rows[1][1:] == pytest.approx([0.0, -1.12, -1.0, 0.0], abs=1e-12)


def test_rig_invert_takes_a_model_stored_in_a_session(tmp_path):
    fit = tmp_path / "fit.h5"
    assert rig_here("acquire", "--levels", "6", "--out", fit, "--no-progress").code == 0
    assert rig_here("identify", fit, "--no-store", "--save", tmp_path / "m.json").code == 0
    assert rig_here("identify", fit, "--name", "mine").code == 0
    y = sines(20) * 0.5
    out = tmp_path / "v.csv"
    r = rig_here("invert", fit, targets_file(tmp_path, y), "--out", out, "--model", "mine", "--json")
    assert r.code == 0, r.err and r.json()["model"] == "mine"
    model = read_session(fit).models["mine"].model
    v = np.array([float(ln.split(",")[1]) for ln in out.read_text().splitlines()[1:]])
    ok = np.array([ln.endswith(",1") for ln in out.read_text().splitlines()[1:]])
    np.testing.assert_allclose(model.predict(v)[ok], y[ok], rtol=0, atol=1e-9)
    r = rig_here("invert", fit, targets_file(tmp_path, y), "--out", out, "--model", "nope")
    assert_one_line_error(r, "no model named 'nope'")
    r = rig_here("invert", fit, targets_file(tmp_path, y), "--out", out)
    assert_one_line_error(r, "already exists")


# ---------------------------------------------------------------- bad input
BAD_TARGETS = {
    "nan": ("t_s,target_um\n1,2\n2,nan\n", "not finite"),
    "empty cell": ("t_s,target_um\n1,2\n2,\n3,1\n", "target_um is empty (a gap"),
    "blank line": ("t_s,target_um\n1,2\n\n3,1\n", "blank line between targets"),
    "times back": ("t_s,target_um\n1,2\n3,1\n2,0\n", "does not increase"),
    "header": ("t_s,y\n1,2\n", "expected the header t_s,target_um"),
    "outside the range": ("t_s,target_um\n1,2\n2,40\n", "outside the model's output range"),
}


@pytest.mark.parametrize("case", list(BAD_TARGETS))
@pytest.mark.parametrize("command", ["invert", "track"])
def test_bad_targets_are_one_line_exit_2_and_nothing_is_written(tmp_path, case, command):
    model_path, _ = true_model(tmp_path)
    text, why = BAD_TARGETS[case]
    target = tmp_path / "t.csv"
    target.write_text(text)
    out = tmp_path / ("v.csv" if command == "invert" else "t.h5")
    args = [model_path, target, "--out", out] if command == "invert" else [model_path, "--target", target, "--out", out]
    assert_one_line_error(rig_here(command, *args), why)
    assert not out.exists()


@pytest.mark.parametrize("command", ["invert", "track"])
def test_a_model_in_other_units_is_refused(tmp_path, command):
    model_path, model = true_model(tmp_path)
    data = model_to_dict(model)
    data["output_unit"] = "A m^2"
    model_path.write_text(json.dumps(data))
    target = targets_file(tmp_path, [1.0, 2.0])
    args = [model_path, target, "--out", tmp_path / "v.csv"] if command == "invert" else \
        [model_path, "--target", target, "--out", tmp_path / "t.h5"]
    assert_one_line_error(rig_here(command, *args), "maps V to A m^2")


def test_a_grid_that_does_not_cover_the_heater_window_is_refused_before_the_rig_is_touched(tmp_path):
    model = model_from_dict({**model_to_dict(true_model(tmp_path)[1])})
    small = dataclasses.replace(model, grid=type(model.grid)(model.grid.levels, 0.0, 3.0))
    path = tmp_path / "small.json"
    path.write_text(json.dumps(model_to_dict(small)))
    out = tmp_path / "t.h5"
    r = rig_here("track", path, "--target", targets_file(tmp_path, [-5.0, -3.0]), "--out", out)
    assert_one_line_error(r, "covers [0, 3] V but the heater's window is [0, 6] V")
    assert not out.exists()


def test_models_that_cannot_be_inverted_are_refused_in_one_line(tmp_path):
    model_path, model = true_model(tmp_path)
    data = model_to_dict(model)
    data["effects"] = [{"name": "first_point", "params": {"coefficients_um": [0.1] * 7, "decay": 0, "cell": 0.2}}]
    model_path.write_text(json.dumps(data))
    r = rig_here("invert", model_path, targets_file(tmp_path, [1.0, 2.0]), "--out", tmp_path / "v.csv")
    assert_one_line_error(r, "cannot invert a model with the effect first_point")


def test_ilc_needs_a_periodic_target(tmp_path):
    model_path, _ = true_model(tmp_path)
    r = rig_here("track", model_path, "--target", targets_file(tmp_path, sines(12)), "--out", tmp_path / "t.h5",
                 "--feedback", "ilc")
    assert_one_line_error(r, "periodic target")
    assert not (tmp_path / "t.h5").exists()


# ---------------------------------------------------------------- rig track on the built-in simulated device
def test_rig_track_follows_the_target_within_the_noise_and_records_every_column(tmp_path):
    model_path, model = true_model(tmp_path)
    y = sines(30)
    out = tmp_path / "t.h5"
    r = rig_here("track", model_path, "--target", targets_file(tmp_path, y), "--out", out, "--json", "--no-progress")
    assert r.code == 0, r.err
    res = r.json()
    for key in ("n", "rmse_um", "max_abs_um", "nrmse", "unreachable", "feedback", "baseline"):
        assert key in res
    assert res["n"] == 30 and res["unreachable"] == 0 and res["feedback"] == "none"
    assert res["rmse_um"] <= 2 * SIGMA  # the device's own model: the error is the sensor's noise
    assert res["baseline"]["linear_inverse_rmse_um"] >= 10 * res["rmse_um"]
    s = read_session(out)
    assert s.status is Status.COMPLETE and s.excitation.kind == "track"
    assert s.extra.dtype.names == TRACKING_COLUMNS.names
    np.testing.assert_array_equal(s.extra["target"], y)
    np.testing.assert_array_equal(s.excitation.targets, y)
    np.testing.assert_allclose(s.extra["predicted"], y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(model.predict(s.inputs), s.extra["predicted"], rtol=0, atol=1e-9)
    assert np.all(s.measured) and "model" in s.models
    np.testing.assert_allclose(s.inputs, s.excitation.inputs)  # without feedback: the feed-forward plan
    # storing a model rewrites the session into a checked copy: the extra columns and the targets go along
    assert rig_here("identify", out, "--levels", "4", "--name", "after").code == 0
    again = read_session(out)
    assert "after" in again.models and "model" in again.models
    np.testing.assert_array_equal(again.extra, s.extra)
    np.testing.assert_array_equal(again.excitation.targets, y)


def test_rig_acquire_resume_refuses_a_tracking_run(tmp_path):
    model_path, _ = true_model(tmp_path)
    out = tmp_path / "t.h5"
    assert rig_here("track", model_path, "--target", targets_file(tmp_path, sines(5)), "--out", out).code == 0
    assert_one_line_error(rig_here("acquire", "--resume", out), "a tracking run", "rig track --resume")
    assert_one_line_error(rig_here("track", "--resume", out), "complete")


# ---------------------------------------------------------------- resuming with feedback
def _plan(model_path, tmp_path, feedback):
    src = load_source(model_path, None)
    targets = read_targets(targets_file(tmp_path, sines(12, repeats=2)))
    return src, plan_track(src, targets, feedback, (0.0, 6.0), dwell_s=None, saturate_s=20.0, readings=2,
                           target_file={})


@pytest.mark.parametrize("feedback", ["pi", "ilc"])
def test_a_resumed_tracking_run_continues_exactly_as_an_uninterrupted_one(tmp_path, feedback):
    """A model 0.3 um off the device (so the feedback has work): stopped by a PSD fault after point 9,
    resumed -- the model's memory and the feedback's learning rebuilt from the session -- it records the
    same set-points and deflections as a run that was never stopped."""
    _, true = true_model(tmp_path)
    off = dataclasses.replace(true, mu0=true.mu0 + 0.3)
    path = tmp_path / "off.json"
    path.write_text(json.dumps(model_to_dict(off)))
    cfg = default_config(psd_noise_V=0.0)
    src, plan = _plan(path, tmp_path, feedback)
    from sessions import TRACKING_COLUMNS as cols

    with open_rig(cfg) as rig:
        acquire(rig, plan.record, tmp_path / "ref.h5", settings=plan.settings,
                setpoints=setpoints_for(plan, off, "ref"), sample_columns=cols, models=(src.record,))
    cut = tmp_path / "cut.h5"
    with open_rig(cfg) as rig:
        with pytest.raises(SensorError):
            acquire(rig, plan.record, cut, settings=plan.settings, hooks=sensor_dies_after(rig, 9),
                    setpoints=setpoints_for(plan, off, "cut"), sample_columns=cols, models=(src.record,))
    assert read_session(cut).n_samples == 10
    with open_rig(cfg) as rig:
        session = read_session(cut)
        resume(rig, cut, setpoints=setpoints_for(session, session.models["model"].model, "cut"))
    ref, s = read_session(tmp_path / "ref.h5"), read_session(cut)
    assert s.status is Status.COMPLETE and s.n_samples == 24
    np.testing.assert_allclose(s.inputs, ref.inputs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s.outputs, ref.outputs, rtol=0, atol=1e-9)
    for name in ("command", "predicted"):
        np.testing.assert_allclose(s.extra[name], ref.extra[name], rtol=0, atol=1e-9)
    assert not np.allclose(s.inputs, s.excitation.inputs)  # the feedback did change the set-points
    e = s.outputs - s.excitation.targets
    assert abs(e[-6:]).max() < 0.5 * abs(e[:3]).max()  # and it learned


def test_rig_track_resume_continues_an_interrupted_run_from_the_command_line(tmp_path):
    model_path, model = true_model(tmp_path)
    src, plan = _plan(model_path, tmp_path, "pi")
    cut = tmp_path / "cut.h5"
    with open_rig(default_config()) as rig:
        with pytest.raises(SensorError):
            acquire(rig, plan.record, cut, settings=plan.settings, hooks=sensor_dies_after(rig, 5),
                    setpoints=setpoints_for(plan, model, "cut"), sample_columns=TRACKING_COLUMNS,
                    models=(src.record,))
    assert_one_line_error(rig_here("track", "--resume", cut, "--feedback", "ilc"), "--feedback cannot be used")
    r = rig_here("track", "--resume", cut, "--json", "--no-progress")  # on the rig configuration it stored
    assert r.code == 0, r.err
    res = r.json()
    assert res["status"] == "complete" and res["n"] == 24 and res["feedback"] == "pi"
    assert res["rmse_um"] <= 3 * SIGMA
    s = read_session(cut)
    assert [e.event for e in s.events][-4:] == ["reopened", "saturated", "replayed", "complete"]


# ---------------------------------------------------------------- over Modbus, against rig serve-sim
SERVED = dict(time_constant_s=0.002, psd_noise_V=0.0005)


@pytest.mark.slow
def test_rig_track_end_to_end_against_rig_serve_sim(tmp_path):
    """A real rig serve-sim process (real clock, pymodbus on 127.0.0.1) driven by rig track through the
    Modbus driver, with PI feedback: the deflection follows the target within the noise, the session holds
    every column, and the heater ends at 0 V, acknowledged."""
    model_path, model = true_model(tmp_path, **SERVED)
    sim = "".join(f"{k} = {v}\n" for k, v in SERVED.items())
    with SimServer(tmp_path, sim="[sim]\n" + sim) as server:
        cfg = server.client_config(tmp_path / "rig.toml", timeout=1.0, retries=2)
        y = sines(24)
        out = tmp_path / "t.h5"
        from rig.testing import rig

        r = rig("track", model_path, "--target", targets_file(tmp_path, y, step=0.05), "--out", out, "--config",
                cfg, "--feedback", "pi", "--saturate", "0.2", "--json", "--no-progress", timeout=120)
        assert r.code == 0, r.err
        res = r.json()
        sigma = 0.0005 * 5.0 / 2
        assert res["n"] == 24 and res["unreachable"] == 0 and res["feedback"] == "pi"
        assert res["rmse_um"] <= 3 * sigma, res
        s = read_session(out)
        assert s.status is Status.COMPLETE and s.driver.get("driver") == "modbus"
        np.testing.assert_allclose(model.predict(s.inputs), s.extra["predicted"], rtol=0, atol=1e-6)
        volts = server.accepted_volts()
        assert volts[-1] == 0.0 and len(volts) >= 25
        np.testing.assert_allclose(volts[2:-1], s.inputs, rtol=1e-6)  # what the heater saw is what is recorded
    assert math.isfinite(res["baseline"]["linear_inverse_rmse_um"])


@pytest.mark.slow
def test_rig_watch_follows_a_tracking_session(tmp_path):
    """The watch reads the standard columns of a tracking session (ignoring the extra ones), its planned rig
    time from the per-point dwells, and fits the model so far on what was measured."""
    from rig.watch.watcher import SessionWatch, WatchOptions, Workers

    model_path, _ = true_model(tmp_path)
    out = tmp_path / "t.h5"
    y = sines(30)
    assert rig_here("track", model_path, "--target", targets_file(tmp_path, y, step=15.0), "--out", out).code == 0
    workers = Workers.start(WatchOptions(method="ls", levels=6))
    try:
        watch = SessionWatch(out, WatchOptions(method="ls", levels=6), workers)
        watch.step(render=False)
        state = watch.build_state()
    finally:
        workers.close()
    s = read_session(out)
    np.testing.assert_array_equal(watch.tail.samples["output"], s.outputs)
    assert state["status"] == "complete" and state["excitation"]["kind"] == "track"
    p = state["progress"]
    assert (p["n_applied"], p["n_points"], p["n_measured"]) == (30, 30, 30)
    assert p["planned_rig_time_s"] == pytest.approx(30 * 15.0)  # the targets' steps
    assert state["quantities"]["output"] == "deflection (µm)"


def test_a_dwell_a_few_ms_longer_than_planned_does_not_make_a_target_unreachable():
    """On the real clock the sequencer records dwells a few ms longer than planned; with a lag in the model the
    output at the recorded dwell differs from the target by what the lag does in those ms.  That is not a
    target out of reach: the flag is the inversion's verdict, and the feedback keeps learning."""
    from identify.effects import EFFECTS
    from identify.inverse import NoFeedback
    from rig.tracking.inverted_setpoints import TrackingSetpoints

    grid = Grid(8, 0.0, 6.0)
    density = np.random.default_rng(3).uniform(0.1, 1.0, grid.n_cells)
    lag = EFFECTS["thermal_lag"]({"drive": "power", "time_constants_s": [5.0, 60.0], "fractions": [0.2, 0.1]})
    model = PreisachModel(grid, density, mu0=-4.0, c_d=-0.3, effects=(lag,))
    targets = np.array([-3.0, 1.0, -1.0, 2.0])
    src = TrackingSetpoints(model, targets, NoFeedback(), (0.0, 6.0), "track")
    for k, y in enumerate(targets):
        t = 2.0 * (k + 1)
        v = src.setpoint(k, t - 2.0, 2.0)
        row = src.measured(k, v, t + 0.004, 2.004, y)
        assert row["reachable"], (k, row)
        assert row["predicted"] != pytest.approx(y, abs=1e-9)  # the recorded dwell did move the model's output
        assert row["predicted"] == pytest.approx(y, abs=1e-2)


def test_rig_track_with_a_wrong_model_warns_and_exits_4(tmp_path):
    """Issue 28, item 5: a sign-flipped model once ended complete, exit 0, no warning (rmse 32.9 um)."""
    model_path, model = true_model(tmp_path)
    flipped = json.loads(model_path.read_text())
    flipped.update(density=(-np.asarray(flipped["density"])).tolist(), mu0=-flipped["mu0"], c_d=-flipped["c_d"],
                   rmse_um=SIGMA)  # what rig identify --json would have said of its own fit
    (tmp_path / "flipped.json").write_text(json.dumps(flipped))
    k = np.arange(24)
    target = targets_file(tmp_path, -1 + 4 * np.cos(2 * np.pi * k / 8))
    r = rig_here("track", tmp_path / "flipped.json", "--target", target, "--out", tmp_path / "t.h5", "--json",
                 "--no-progress")
    assert r.code == 4, r.err
    res = r.json()
    assert res["status"] == "complete" and res["rmse_um"] > 1.0 and res["model_fit_rmse_um"] == SIGMA
    assert "far beyond 10 x the model's own fit error" in res["warning"]
    assert [ln for ln in r.err.splitlines() if ln.startswith("warning: ")] == [f"warning: {res['warning']}"]
    # the right model: no warning, exit 0
    r = rig_here("track", model_path, "--target", target, "--out", tmp_path / "ok.h5", "--json", "--no-progress")
    assert r.code == 0 and r.json()["warning"] is None, r.err


def test_messages_name_the_file_line_of_a_target(tmp_path):
    """Issue 28, item 14: targets were numbered from 0 in messages while a user counts file lines."""
    model_path, _ = true_model(tmp_path)
    target = tmp_path / "t.csv"
    target.write_text("t_s,target_um\n1,2\n2,3\n3,40\n")  # the third target is on line 4
    for command, args in (("invert", [model_path, target, "--out", tmp_path / "v.csv"]),
                          ("track", [model_path, "--target", target, "--out", tmp_path / "t.h5"])):
        assert_one_line_error(rig_here(command, *args), f"{target}: the target on line 4 (40 um)")


@pytest.mark.parametrize("command", ["invert", "predict"])
def test_a_model_whose_range_contradicts_its_walls_is_refused(tmp_path, command):
    """Issue 28, item 15: a model JSON whose v_min/v_max contradict its walls was accepted."""
    model_path, model = true_model(tmp_path)
    data = model_to_dict(model)
    data["v_max"] = 3.0  # its walls end at 6 V
    model_path.write_text(json.dumps(data))
    trace = tmp_path / "tr.csv"
    trace.write_text("t_s,v_V,deflection_um\n0,1,0\n1,2,0\n")
    args = [model_path, targets_file(tmp_path, [1.0, 2.0]), "--out", tmp_path / "v.csv"] if command == "invert" else \
        [model_path, trace]
    assert_one_line_error(rig_here(command, *args), "v_max=3.0 but its walls end at 6")
