"""``rig diagnose`` on sessions recorded by the sequencer on the simulated bench: the --json contract,
the readable report, the figures, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from identify.diagnosis import NAMES
from identify.effects import EFFECTS

from rig.diagnosis.demo import diagnose_simulated
from rig.diagnosis.simulate import SimulatedBench, simulate
from sessions import Trace, read_session, write_trace

from .cli import assert_one_line_error, rig_here

#: Small and quick: L = 8 (38 identification points), 100 check points.
SMALL = dict(levels=8, check_points=100)


@pytest.fixture(scope="module")
def creep_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("creep")
    return simulate(SimulatedBench("creep", 0.1, seed=1, **SMALL), d)


@pytest.mark.slow
def test_json_follows_the_contract_and_names_the_effect(creep_runs, tmp_path):
    fit, check = creep_runs
    run = rig_here("diagnose", "--fit", fit, "--check", check, "--json", "--out", tmp_path / "figs")
    assert run.code == 0, run.err
    out = json.loads(run.out)
    assert {"baseline", "where", "candidates", "verdict"} <= set(out)
    assert {"rmse_um", "noise_floor_um"} <= set(out["baseline"])
    assert [w["by"] for w in out["where"]] == ["input_V", "branch", "time_since_reversal_s", "last_step_V",
                                               "predicted_um", "session_time_s"]
    for w in out["where"]:
        assert w["bins"] and all({"lo", "hi", "mean_um", "rms_um", "n", "significant"} <= set(b) for b in w["bins"])
        assert sum(b["n"] for b in w["bins"]) == out["baseline"]["n_points"]
    scored = {c["effect"] for c in out["candidates"]}
    assert scored | {e["effect"] for e in out["not_assessed"]} == set(NAMES) and set(EFFECTS) <= scored
    for c in out["candidates"]:
        assert {"effect", "rmse_um", "shrink", "ci", "params"} <= set(c) and len(c["ci"]) == 2
        assert c["ci"][0] <= c["shrink"] <= c["ci"][1]
    v = out["verdict"]
    assert {"status", "effect", "shrink"} <= set(v)
    assert v["status"] == "explained" and v["effect"] == "creep"
    assert v["look_alikes"] == {}  # no mechanism outside the library is known to look like creep
    best = out["candidates"][0]
    assert best["effect"] == "creep" and v["shrink"] == pytest.approx(best["shrink"])
    assert best["rmse_um"] == pytest.approx(out["baseline"]["rmse_um"] * (1 - best["shrink"]))
    assert best["params"]["um_per_V"] > 0  # the simulated creep offsets in the direction of the excursion
    # the figures are real PNGs
    for name in ("where.png", "candidates.png"):
        data = (tmp_path / "figs" / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    assert out["figures"] == [str(tmp_path / "figs" / n) for n in ("where.png", "candidates.png")]


def test_readable_report_and_a_smaller_library(creep_runs):
    fit, check = creep_runs
    run = rig_here("diagnose", "--fit", fit, "--check", check)
    assert run.code == 0, run.err
    assert "Verdict: EXPLAINED by creep" in run.out and "How far: held-out RMSE" in run.out
    assert "Where (residual = model - measured" in run.out and "Which (held-out" in run.out
    # the same data, with creep's own candidate withheld: never a wrong name
    run = rig_here("diagnose", "--fit", fit, "--check", check, "--json",
                   "--effects", "thermal_lag,baseline_drift,ambient_drift,joule_power,sensor_nonlinearity")
    out = json.loads(run.out)
    assert out["verdict"]["status"] in ("unexplained", "ambiguous") and out["verdict"]["effect"] is None
    assert "creep" not in {c["effect"] for c in out["candidates"]}


def test_no_effect_is_no_gap_through_the_demo_function(tmp_path):
    result = diagnose_simulated(None, seed=2, directory=tmp_path, **SMALL)
    assert result.json["verdict"]["status"] == "no_gap"
    assert result.json["verdict"]["effect"] is None
    assert read_session(result.fit_path).status.value == "complete"
    assert "Verdict: NO GAP" in result.text


def test_two_check_runs_and_grid_mismatches_are_reported(creep_runs, tmp_path):
    fit, check = creep_runs
    other = simulate(SimulatedBench("creep", 0.1, seed=4, levels=10, check_points=60), tmp_path)[1]
    run = rig_here("diagnose", "--fit", fit, "--check", check, other, "--json")
    assert run.code == 0, run.err
    out = json.loads(run.out)
    assert out["check"] == [str(check), str(other)]
    assert any("L=10" in w and "diagnosis grid L=8" in w for w in out["warnings"])
    assert out["baseline"]["n_points"] == 160


def test_bad_input_is_one_line_and_exit_2(creep_runs, tmp_path):
    fit, check = creep_runs
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not a session")
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", junk), "junk.h5", "not an HDF5 file")
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", fit), "also an identification run")
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", check, "--effects", "gremlins"),
                          "unknown effect")
    trace = tmp_path / "t.csv"
    s = read_session(check)
    write_trace(trace, Trace(s.t_s, s.inputs, s.outputs))
    assert_one_line_error(rig_here("diagnose", "--fit", trace, "--check", check), "records no grid", "--levels")
    # a check run entirely outside the identification range cannot be judged
    far = tmp_path / "far.csv"
    write_trace(far, Trace(np.arange(20.0), np.full(20, 6.5), np.zeros(20)))
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", far, "--v-max", 6.0),
                          "inside the identification range")


def test_the_verdict_names_what_else_a_named_family_reaches():
    from identify.effects import EFFECTS
    from rig.diagnosis.report import look_alikes

    got = look_alikes(["creep", "ambient_drift", "no_such_effect", "sensor_nonlinearity"])
    assert list(got) == ["ambient_drift", "sensor_nonlinearity"]
    assert got["ambient_drift"] == list(EFFECTS["ambient_drift"].look_alikes)
    assert any("heater" in a for a in got["ambient_drift"])  # a heater ageing changes the rise per volt too
    assert look_alikes([]) == {}


def test_the_fitted_line_shows_each_runs_drift_and_leaves_sequences_to_the_json():
    from rig.diagnosis.report import _params_text

    params = {"runs": {"fit": {"rms_um": 0.0046, "range_um": 0.0158, "change_um": 0.00127,
                               "knots_s": [20.0, 605.3], "coefficients": [-0.004, 0.001]},
                       "check": {"rms_um": 0.002, "knots_s": [1.0]}},
              "form": "gain", "empty": {}, "spectrum": {"at_2s": 0.25}}
    assert _params_text(params) == ("runs {fit {rms_um 0.0046, range_um 0.0158, change_um 0.00127}, "
                                    "check {rms_um 0.002}}, form gain, spectrum {at_2s 0.25}")
