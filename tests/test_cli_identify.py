"""``rig identify`` / ``rig predict``: the JSON contract, exact recovery, bad input."""

import json

import numpy as np
import pytest

from identify import damped_oscillation, random_input
from rig.testing import rig

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model, write_csv


@pytest.fixture
def damped_csv(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    v = damped_oscillation(truth.grid, thermal_term=True)
    return truth, write_csv(tmp_path / "damped.csv", v, truth.predict(v))


def test_identify_json_contract_and_exact_recovery(damped_csv, tmp_path):
    truth, path = damped_csv
    before = digest(path)
    run = rig_here("identify", path, "--levels", 6, "--method", "cs_order_nn", "--json")
    assert run.code == 0, run.err
    out = run.json()
    for key in ("method", "levels", "walls", "mu0", "c_d", "density", "rmse_um", "n_measured"):
        assert key in out
    assert out["method"] == "cs_order_nn" and out["levels"] == 6
    assert len(out["walls"]) == 7 and out["walls"][0] == 0.0 and out["walls"][-1] == 3.0
    d = np.array(out["density"])
    assert d.shape == (6, 6) and np.all(d[np.triu_indices(6, 1)] == 0)
    np.testing.assert_allclose(d, truth.density_matrix(), rtol=1e-6, atol=1e-9)
    assert out["mu0"] == pytest.approx(truth.mu0, rel=1e-6)
    assert out["c_d"] == pytest.approx(truth.c_d, rel=1e-6)
    assert out["n_measured"] == 23 and out["rmse_um"] < 1e-6
    assert digest(path) == before


@pytest.mark.slow
def test_identify_then_predict_round_trip(damped_csv, tmp_path):
    truth, path = damped_csv
    model_file = tmp_path / "model.json"
    run = rig("identify", path, "-L", 6, "--method", "ls", "--measurements", 15, "--seed", 3,
              "--json", "--save", model_file)
    assert run.code == 0, run.err
    assert run.json()["n_measured"] == 15
    assert json.loads(model_file.read_text()) == run.json()
    # the identify output itself is also a model file
    stdout_model = tmp_path / "stdout.json"
    stdout_model.write_text(run.out)
    v = random_input(truth.grid, 50, seed=4)
    check = write_csv(tmp_path / "check.csv", v, truth.predict(v))
    for m in (model_file, stdout_model):
        p = rig("predict", m, check, "--json")
        assert p.code == 0, p.err
        res = p.json()
        assert {"prediction_um", "rmse_um", "max_abs_um"} <= set(res)  # the contract; docs/reference/commands/predict.md lists the rest
        assert len(res["prediction_um"]) == 50 and res["n_points"] == res["n_measured"] == 50
        err = np.array(res["prediction_um"]) - truth.predict(v)
        assert res["rmse_um"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-9)
        assert res["max_abs_um"] == pytest.approx(np.abs(err).max(), rel=1e-9)


def test_human_readable_output(damped_csv):
    _, path = damped_csv
    run = rig_here("identify", path, "-L", 6)
    assert run.code == 0 and "rmse_um" in run.out and "ls on L=6" in run.out


def test_no_thermal_term(tmp_path):
    truth = known_model(5, c_d=0.0)
    v = damped_oscillation(truth.grid)
    path = write_csv(tmp_path / "d.csv", v, truth.predict(v))
    out = rig_here("identify", path, "-L", 5, "--no-thermal-term", "--method", "cs", "--json").json()
    assert out["c_d"] == 0.0 and out["thermal_term"] is False
    assert out["mu0"] == pytest.approx(truth.mu0, rel=1e-6)


BAD_CSVS = {
    "nonfinite": ("t_s,v_V,deflection_um\n0,1,2\n1,nan,3\n", "not finite"),
    "inf": ("t_s,v_V,deflection_um\n0,1,2\n1,2,inf\n", "not finite"),
    "wrong_header": ("time,v_V,deflection_um\n0,1,2\n", "missing column"),
    "missing_column": ("t_s,v_V\n0,1\n", "deflection_um"),
    "short_row": ("t_s,v_V,deflection_um\n0,1,2\n1,2\n", "line 3"),
    "not_number": ("t_s,v_V,deflection_um\n0,1,2\n1,abc,3\n", "'abc'"),
    "empty": ("", "empty"),
    "header_only": ("t_s,v_V,deflection_um\n", "no data rows"),
}


@pytest.mark.parametrize("case", list(BAD_CSVS))
def test_bad_csv_is_one_line_exit_2_and_untouched(tmp_path, case):
    text, fragment = BAD_CSVS[case]
    path = tmp_path / f"{case}.csv"
    path.write_text(text)
    before = digest(path)
    assert_one_line_error(rig_here("identify", path, "--levels", 3), fragment)
    assert digest(path) == before


def test_bad_arguments(damped_csv, tmp_path):
    _, path = damped_csv
    before = digest(path)
    assert_one_line_error(rig_here("identify", path, "--levels", 0), "levels")
    assert_one_line_error(rig_here("identify", path), "--levels")
    assert_one_line_error(rig_here("identify", path, "-L", 6, "--measurements", 24), "between 1 and N=23")
    assert_one_line_error(rig_here("identify", path, "-L", 6, "--measurements", 0), "between 1 and N")
    assert_one_line_error(rig_here("identify", path, "-L", 6, "--method", "nope"), "nope")
    assert_one_line_error(rig_here("identify", tmp_path / "missing.csv", "-L", 3), "no such file")
    assert_one_line_error(rig_here("identify", path, "-L", 7, "--method", "cs"), "square")
    assert_one_line_error(rig_here("identify", path, "-L", 6, "--v-min", 4, "--v-max", 1), "v_max > v_min")
    assert digest(path) == before


def test_predict_bad_model(tmp_path, damped_csv):
    _, path = damped_csv
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert_one_line_error(rig_here("predict", bad, path, "--json"), "not a JSON model")
    bad.write_text(json.dumps({"walls": [0, 1], "mu0": 0}))
    assert_one_line_error(rig_here("predict", bad, path, "--json"), "missing")
    assert_one_line_error(rig_here("predict", tmp_path / "none.json", path), "no such file")


def test_a_grid_that_does_not_match_the_session_is_named_and_too_many_cells_need_yes(tmp_path):
    """Issue 28, item 12: -L 1000 on an L = 5 session blamed 'every measured input sits on a wall', and with
    --no-thermal-term fitted 500,500 cells from 17 points, exit 0, without a word."""
    s = tmp_path / "S.h5"
    assert rig_here("acquire", "--levels", 5, "--dwell", 1, "--readings", 1, "--out", s).code == 0
    before = digest(s)
    for extra in ((), ("--no-thermal-term",)):
        assert_one_line_error(rig_here("identify", s, "-L", 100, *extra), "5,050 cells", "17 measured points",
                              "can identify at most 17", "does not match the session's inputs", "L = 5", "--yes")
    assert_one_line_error(rig_here("identify", s, "-L", 10), "every measured input sits on a wall of the L = 10 grid",
                          "does not match the session's inputs", "-L 5")
    assert digest(s) == before
    r = rig_here("identify", s, "-L", 100, "--no-thermal-term", "--yes", "--no-store", "--json")
    assert r.code == 0 and r.json()["levels"] == 100, r.err  # asked for: fitted
    assert rig_here("identify", s, "--no-store").code == 0  # the session's own grid


@pytest.mark.parametrize("spec", ["", " ", "creep,", ",creep"])
def test_an_empty_effect_name_is_refused_not_taken_for_none(damped_csv, spec):
    """Issue 28, item 15: --with '' was accepted as 'no effect'."""
    assert_one_line_error(rig_here("identify", damped_csv[1], "-L", 4, "--with", spec), "names an empty effect")
