"""``rig acquire --rig-time S``: a plan within a rig-time budget, and the lag it relies on.

* :func:`identify.rig_time.plan_within` keeps its budget, gives the reversal points the longest dwell,
  refuses a budget below what the grid can identify (naming the least one) and is reproducible;
* ``thermal_lag:dominant`` recovers a lag as long as the dwells from a run of the simulated device
  (``drivers.sim``, first-order lag), where the plain ``thermal_lag`` steps from zero cannot;
* the command plans, states the plan before the rig is touched, records the recipe ``rig identify``
  uses, and refuses contradictions and impossible budgets with exit 2, writing nothing.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.sim.device import SimVO2
from drivers.sim.params import SimParams
from identify import Excitation, Grid, IdentifyError
from identify.acquisition_plan import reversal_points
from identify.effects import parse_effects
from identify.fit import fit_run
from identify.rig_time import MIN_DWELL_S, least_budget_s, plan_within
from identify.runs import Run

from .acquirekit import refused_before_writing, virtual_sim_config
from .cli import rig_here

GRID = Grid(8, 0.0, 6.0)


def _reference() -> "object":
    return SimVO2(SimParams(levels=8)).true_model()


def test_a_plan_keeps_its_budget_and_gives_reversals_the_longest_dwell():
    plan = plan_within(GRID, 200.0, _reference(), reading_s=0.01, noise_um=0.01, seed=3)
    n = Excitation.damped(GRID, True).inputs.size
    assert plan.n_points == n and plan.dwell_s.shape == (n,)
    spent = plan.dwell_s.sum() + n * plan.readings * 0.01
    assert spent == pytest.approx(plan.rig_time_s) and spent <= 200.0 + 1e-9
    assert np.all(plan.dwell_s >= MIN_DWELL_S)
    if plan.chosen.kind == "model":
        rev = reversal_points(plan.inputs)
        assert plan.dwell_s[rev].min() >= plan.dwell_s[~rev].max()
        assert plan.effects == ("thermal_lag:dominant",)
    again = plan_within(GRID, 200.0, _reference(), reading_s=0.01, noise_um=0.01, seed=3)
    assert np.array_equal(again.dwell_s, plan.dwell_s) and again.chosen == plan.chosen


def test_a_budget_below_the_least_is_refused_naming_it():
    least = least_budget_s(GRID, True, 0.0)
    n = Excitation.damped(GRID, True).inputs.size
    assert least == pytest.approx(n * MIN_DWELL_S)
    with pytest.raises(IdentifyError, match=rf"least budget is {least:.0f} s"):
        plan_within(GRID, 0.5 * least, _reference())
    with pytest.raises(IdentifyError, match="positive"):
        plan_within(GRID, -1.0, _reference())


def _sim_run(tau: float, inputs: np.ndarray, dwell: np.ndarray) -> Run:
    clock = VirtualClock()
    dev = SimVO2(SimParams(levels=8, time_constant_s=tau, psd_noise_V=0.0), clock)
    dev.apply_voltage(0.0)
    clock.sleep(100 * tau)
    y = np.empty(inputs.size)
    for k, (v, d) in enumerate(zip(inputs, dwell)):
        dev.apply_voltage(float(v))
        clock.sleep(float(d))
        y[k] = dev.read_psd() * dev.params.psd_um_per_V
    return Run("r", inputs, y, np.cumsum(dwell), dwell)


def test_dominant_lag_is_recovered_where_steps_from_zero_are_not():
    tau = 2.0
    inputs = Excitation.damped(GRID, True).inputs
    rev = reversal_points(inputs)
    dwell = np.random.default_rng(0).choice([0.3, 0.8, 1.5], size=inputs.size)
    dwell[rev] = 15.0
    run = _sim_run(tau, inputs, dwell)
    rep = fit_run(GRID, run, "ls", parse_effects("thermal_lag:dominant"))
    lag = rep.model.effects[0].report()
    assert lag["mean_time_constant_s"] == pytest.approx(tau, rel=0.02)
    assert lag["fraction"] == pytest.approx(1.0, abs=0.02)
    assert rep.rmse < 1e-3 * np.ptp(run.outputs)
    plain = fit_run(GRID, run, "ls", parse_effects("thermal_lag"))
    assert plain.rmse > 10 * rep.rmse  # the reason for the option


def test_rig_acquire_rig_time_plans_runs_and_records_the_recipe(tmp_path):
    cfg, out = virtual_sim_config(tmp_path, 8, 2.0), tmp_path / "fast.h5"
    r = rig_here("acquire", "--config", cfg, "--rig-time", 150, "--out", out, "--json")
    assert r.code == 0, r.err
    summary = r.json()
    assert summary["status"] == "complete" and summary["rig_time_s"] <= 150.0 + 1e-6
    assert "rig-time plan:" in r.err and "of 150 s" in r.err
    plan = summary["rig_time_plan"]
    assert plan["budget_s"] == 150 and plan["rig_time_s"] <= 150 + 1e-6 and len(plan["candidates"]) >= 1
    assert plan["kind"] in ("model", "wait") and plan["readings"] >= 1
    recipe = summary["identify_recipe"]
    assert recipe["method"] == "ls" and "--rig-time 150" in recipe["reason"]
    ident = rig_here("identify", out, "--json")
    assert ident.code == 0, ident.err
    model = ident.json()
    if recipe["effects"]:
        assert [e["name"] for e in model["effects"]] == ["thermal_lag"]


@pytest.mark.parametrize("args, message", [
    (["--rig-time", "1"], "least budget is"),
    (["--rig-time", "0"], "positive"),
    (["--rig-time", "150", "--dwell", "5"], "--dwell contradicts"),
    (["--rig-time", "150", "--measure", "40"], "--measure contradicts"),
    (["--rig-time", "150", "--sequence", "random"], "not --sequence random"),
])
def test_rig_time_bad_input_exits_2_and_writes_nothing(tmp_path, args, message):
    refused_before_writing(virtual_sim_config(tmp_path, 8, 2.0), tmp_path, args, message)


def test_a_set_point_of_zero_volts_after_heating_is_still_warm():
    """The lag of a beam heated to 6 V and set to 0 V for less than its time constant: the hysterons feel the
    warm beam (hand-computed: p = 36 exp(-1 / 2) V^2, x = 6 exp(-1 / 4) V), not negative saturation."""
    from identify.effects.thermal_lag import lagged

    run = Run("r", np.array([6.0, 0.0]), np.zeros(2), np.array([100.0, 101.0]), np.array([100.0, 1.0]))
    x = lagged(run, 2.0, 1.0, drive="power")
    assert x[1] == pytest.approx(6.0 * np.exp(-0.25), rel=1e-9)
