"""Bounded work: a long job says what it costs before it starts, and a huge one is refused (issue 17,
finding 4).

``rig acquire --levels 10000`` started a 50-million-point plan (458 MB written in
96 s; 31 years of rig time at 20 s a point) and ``rig identify --levels 10000``
ran 5+ minutes at 4 GB, both without a word.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from identify import Excitation
from rig.budget.acquisition import MAX_POINTS, estimate_acquisition, planned_points
from rig.budget.limits import Exceeded, format_duration, refuse_unless_confirmed
from rig.errors import UserError

from .cli import assert_one_line_error, rig_here
from .conftest import known_model
from .sessionkit import write_run

REAL_CLOCK_SIM = """driver = "sim"
clock = "real"
[heater]
max_V = 6.0
[sensor]
um_per_V = 5.0
"""


def test_a_50_million_point_plan_is_refused_before_it_is_built(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("the plan was built")

    monkeypatch.setattr(Excitation, "damped", never)
    out = tmp_path / "big.h5"
    run = rig_here("acquire", "--levels", 10000, "--out", out)
    assert_one_line_error(run, "rig acquire: the plan has 50,005,002 points (limit 1,000,000)", "--yes")
    assert not out.exists()
    assert planned_points("damped", 30, None, True, 30, 200) == 467  # the damped oscillation's N + 1
    assert planned_points("random", None, 5, True, 30, 200) == 5 and planned_points("x.csv", 4, None, True, 30,
                                                                                     200) is None


def test_a_run_states_its_points_and_rig_time_first_and_the_estimate_is_the_run(tmp_path):
    out = tmp_path / "s.h5"
    run = rig_here("acquire", "--levels", 6, "--dwell", 3, "--transit", 0.5, "--measure", 15, "--out", out,
                   "--no-progress", "--json")
    assert run.code == 0, run.err
    summary = run.json()
    plan_line = run.err.splitlines()[0]
    assert plan_line.startswith(f"plan: {summary['n_points']} points ({summary['n_planned_measured']} measured, "
                                f"{summary['n_reversals']} reversal points); rig time ")
    assert "virtual clock" in plan_line and "session file about" in plan_line and "memory about" in plan_line
    # with fixed waits the estimate is the run: the saturation dwell plus every point's wait
    from sessions import read_session

    s = read_session(out)
    from identify.acquisition_plan import reversal_points

    cost = estimate_acquisition(s.excitation.measure, reversal_points(s.inputs), 3.0, 0.5, None, False, True)
    assert cost.rig_time_s - 3.0 == pytest.approx(summary["rig_time_s"], abs=1e-6)
    assert format_duration(cost.rig_time_s) in plan_line
    assert cost.session_bytes == pytest.approx(out.stat().st_size, rel=0.5)


def test_a_week_of_real_rig_time_is_refused_unless_confirmed(tmp_path):
    config = tmp_path / "rig.toml"
    config.write_text(REAL_CLOCK_SIM)
    out = tmp_path / "s.h5"
    # 200 random points at an hour each: 8.3 days on a real clock
    run = rig_here("acquire", "--config", config, "--sequence", "random", "--dwell", 3600, "--out", out)
    assert_one_line_error(run, "rig time 8 d 09:00:00 (limit 7 d 00:00:00)", "nothing was started", "--yes")
    assert not out.exists()
    # the same plan on the virtual clock costs no waiting: allowed (and stated)
    run = rig_here("acquire", "--sequence", "random", "--points", 20, "--dwell", 3600, "--out", out, "--no-progress")
    assert run.code == 0, run.err
    assert "rig time 21:00:00 (virtual clock" in run.err


def test_one_duration_convention_in_the_plan_the_progress_and_the_summary(tmp_path):
    """Issue 28, item 13: '--levels 200 --dwell 3600' planned '2.3 years' and reported 'rig time 20102:00:00'."""
    import re

    run = rig_here("acquire", "--levels", 40, "--dwell", 3600, "--readings", 1, "--out", tmp_path / "s.h5",
                   "--progress")
    assert run.code == 0, run.err
    durations = re.findall(r"rig time ([^(,\]\n]*?)(?: \(| on |,|\]|$)", run.err + run.out, re.M)
    assert len(durations) >= 3, (run.err, run.out)  # the plan, the progress bar, the summary
    for d in durations:  # the progress bar passes through hours on its way
        assert re.fullmatch(r"\d+ d \d\d:\d\d:\d\d|\d+:\d\d:\d\d", d), (d, durations)
    assert re.fullmatch(r"\d+ d \d\d:\d\d:\d\d", durations[0]) and re.fullmatch(r"\d+ d \d\d:\d\d:\d\d", durations[-1])
    assert format_duration(3.9) == "3.9 s" and format_duration(42) == "42 s" and format_duration(9340) == "2:35:40"
    assert format_duration(20102 * 3600) == "837 d 14:00:00"


def test_confirmation_lets_a_job_over_the_limits_run():
    over = [Exceeded("the plan has", f"{MAX_POINTS + 1:,} points", f"{MAX_POINTS:,}")]
    with pytest.raises(UserError, match="add --yes"):
        refuse_unless_confirmed("rig acquire", over, yes=False)
    refuse_unless_confirmed("rig acquire", over, yes=True)
    refuse_unless_confirmed("rig acquire", [], yes=False)


@pytest.fixture
def session(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    path, _ = write_run(tmp_path / "s.h5", truth, Excitation.damped(truth.grid))
    return path


def test_a_fit_of_50_million_parameters_is_refused_before_it_starts(session, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("the fit started")

    monkeypatch.setattr("rig.reidentify.fit_run", never)
    run = rig_here("identify", session, "--levels", 10000, "--no-store")
    assert_one_line_error(run, f"rig identify {session}: ", "estimated memory", "(limit 4 GB)", "--yes")
    # --force (replace a stored model) is not the confirmation: --yes is
    assert "--force" not in run.err


def test_a_long_fit_is_announced_with_its_estimate(session, monkeypatch):
    monkeypatch.setattr("rig.commands.identify.PROGRESS_AFTER_S", 0.0)
    monkeypatch.setattr("rig.budget.identification.PROGRESS_AFTER_S", 0.0)
    run = rig_here("identify", session, "--method", "smooth_nn", "--levels", 8, "--no-store", "--json")
    assert run.code == 0, run.err
    assert f"{session}: smooth_nn on L = 8 (38 parameters), 23 measured of 23 points: about " in run.err
    assert "(estimated)" in run.err and run.json()["levels"] == 8


def test_identify_reports_its_stages_and_the_progress_line_counts_down(monkeypatch):
    import io
    import time

    from identify import Grid, damped_oscillation
    from identify.fit import fit_sequence
    from rig.fit_progress import FitProgress, fit_in_process

    grid = Grid(4, 0.0, 1.0)
    v = damped_oscillation(grid, thermal_term=True)
    stages = []
    fit_sequence(grid, v, known_model(4, 0.0, 1.0).predict(v), "ls", progress=stages.append)
    assert stages == ["fitting", "scoring"]  # identify only calls the hook; it prints nothing

    stream = io.StringIO()
    with FitProgress("rig identify: s.h5", 10.0, stream=stream, enabled=True) as shown:
        shown.stage("fitting")
        first = shown.line()
        time.sleep(1.1)  # at least one redraw by the timer
    drawn = stream.getvalue()
    assert "rig identify: s.h5: fitting, " in first and "about 10 s left" in first
    assert drawn.count("\r") >= 3 and drawn.endswith("\r")  # redrawn, then erased
    late = FitProgress("x", 1.0, stream=io.StringIO(), enabled=True)
    assert late.line(now=late._start + 5.0).endswith("taking longer than estimated")

    # only the fits estimated to be long get the line
    class Cost:
        def __init__(self, seconds):
            self.seconds = seconds

    calls = []

    def fit(job, progress=None):
        calls.append((job, progress is not None))
        return job

    assert fit_in_process(fit, ["quick", "slow"], [Cost(0.1), Cost(60.0)], ["a", "b"], enabled=False) == ["quick",
                                                                                                          "slow"]
    assert calls == [("quick", False), ("slow", True)]


@pytest.mark.slow
def test_the_demo_reports_each_step_as_it_starts(tmp_path):
    from rig.demo_pipeline import DemoSettings, run_demo

    steps = []
    run_demo(DemoSettings(levels=4, measurements=10, effect=None), tmp_path / "d", progress=steps.append)
    assert steps == ["1/4 acquiring", "2/4 identifying", "3/4 diagnosing", "4/4 reporting"]
