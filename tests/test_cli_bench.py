"""``rig identify --solver`` and ``rig bench``: the JSON contracts."""

import numpy as np
import pytest

from identify import damped_oscillation
from identify.methods import DAMPED_METHODS

from .cli import assert_one_line_error, rig_here
from .conftest import known_model, write_csv


@pytest.mark.slow
def test_identify_solver_choice_gives_the_same_model(tmp_path):
    truth = known_model(5, v_min=0.0, v_max=3.0)
    v = damped_oscillation(truth.grid, thermal_term=True)
    y = truth.predict(v) + np.random.default_rng(0).uniform(-0.01, 0.01, v.size)
    path = write_csv(tmp_path / "d.csv", v, y)
    out = {}
    for solver in ("fast", "dense"):
        run = rig_here("identify", path, "-L", 5, "--method", "cs_order_nn", "--measurements", 12,
                  "--solver", solver, "--json")
        assert run.code == 0, run.err
        out[solver] = run.json()
        assert out[solver]["settings"]["solver"] == solver
    np.testing.assert_allclose(out["fast"]["density"], out["dense"]["density"], atol=1e-6)
    assert_one_line_error(rig_here("identify", path, "-L", 5, "--solver", "magic"), "solver")


@pytest.mark.slow
def test_bench_json_contract_covers_every_method_for_the_damped_oscillation():
    run = rig_here("bench", "--case", "3:5", "--dense-up-to", "0", "--repeats", "1", "--json")
    assert run.code == 0, run.err
    cases = run.json()["cases"]
    assert [c["method"] for c in cases] == list(DAMPED_METHODS)
    for c in cases:
        for key in ("levels", "method", "fast_s", "dense_s", "ratio", "peak_mb", "rmse_rel_diff"):
            assert key in c
        assert c["levels"] == 3 and c["status"] == "ok", c
        assert c["fast_s"] > 0 and c["peak_mb"] > 10  # a whole Python process
        assert c["dense_s"] is None and c["ratio"] is None and c["rmse_rel_diff"] is None


@pytest.mark.slow
def test_bench_against_the_dense_reference_and_bad_cases():
    run = rig_here("bench", "--case", "4:8", "--method", "cs_order", "--repeats", "2", "--json")
    assert run.code == 0, run.err
    (case,) = run.json()["cases"]
    assert case["runs"] == 2 and case["dense_status"] == "ok"
    assert case["ratio"] == pytest.approx(case["dense_s"] / case["fast_s"])
    assert 0 <= case["rmse_rel_diff"] < 1e-6  # a unique l1 optimum, reached by both
    assert case["fast_rmse_um"] == pytest.approx(case["dense_rmse_um"], rel=1e-6)
    assert_one_line_error(rig_here("bench", "--case", "30:9999"), "M <= N+1")
    assert_one_line_error(rig_here("bench", "--case", "thirty"), "L:M")
