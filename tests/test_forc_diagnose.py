"""``rig diagnose`` on FORC sessions: the curve split, the thinned history, units, effects that cannot
apply, and the drift monitor."""

from __future__ import annotations

import numpy as np
import pytest

from identify import Grid
from identify.diagnosis import Run, diagnose
from identify.diagnosis.candidates import drift_at
from identify.diagnosis.noise import from_monitor
from rig.diagnosis.loading import thin_rows, thin_run
from sessions import read_session

from .cli import assert_one_line_error, rig_here
from .conftest import write_csv
from .forcfiles import Relays, forc_data, lines_0016, shared_forc, write_lines
from .test_forc_identify import GRID, REVERSALS, protocol, truth_model

HEATER_EFFECTS = {"thermal_lag", "ambient_drift", "joule_power"}


def test_thin_rows_keeps_every_kth_point_of_each_curve_from_its_first():
    curves = np.array([-1, -1, 0, 0, 0, 0, 0, -1, -1, 1, 1, 1, 1])
    rows = np.flatnonzero(curves >= 0)
    np.testing.assert_array_equal(thin_rows(curves, rows, 2), [2, 4, 6, 9, 11])
    np.testing.assert_array_equal(thin_rows(curves, rows, 3), [2, 5, 9, 12])
    np.testing.assert_array_equal(thin_rows(curves, rows, 1), rows)


def test_thinned_history_leaves_every_kept_point_in_its_memory_state():
    model = truth_model()
    v, y, c = protocol(model, REVERSALS)
    even = np.flatnonzero((c >= 0) & (c % 2 == 0))
    kept = thin_rows(c, even, 3)
    outputs = np.full(v.size, np.nan)
    outputs[kept] = y[kept]
    run = Run("forc:even", v, outputs, np.arange(v.size, dtype=float), np.full(v.size, np.nan),
              input_unit="T", output_unit="A m^2", by_curves=True)
    thin = thin_run(run)
    # far fewer points: the odd curves shrink to their turning points, the even ones to the kept points
    assert thin.n < 0.5 * run.n and np.isfinite(thin.outputs).sum() == kept.size
    np.testing.assert_array_equal(thin.outputs[np.isfinite(thin.outputs)], y[kept])
    # the same model answers the same at every kept point: the memory state is unchanged
    np.testing.assert_allclose(model.predict(thin.inputs)[np.isfinite(thin.outputs)], model.predict(v)[kept],
                               rtol=0, atol=1e-12)
    # and the reversal field of every kept curve point is its curve's
    rev = thin.history.reversal_V[np.isfinite(thin.outputs)]
    np.testing.assert_allclose(rev, REVERSALS[c[kept]])


def test_drift_monitor_noise_is_a_sixth_of_the_mean_square_of_second_differences_and_ignores_a_linear_drift():
    zigzag = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0])   # second differences -2, 2, -2, 2, -2
    drifting = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 1.0]) + 0.25 * np.arange(6)  # the drift cancels: 2, -2, 2, -2
    est = from_monitor([zigzag, drifting])
    # nine second differences of +-2: mean square 4, sigma^2 = 4 / 6
    assert est.sigma_um == pytest.approx(np.sqrt(4.0 / 6.0)) and est.source == "drift_monitor" and est.measured
    # the same zigzag on a steep drift gives the same noise (first differences would add the slope)
    assert from_monitor([zigzag, drifting + 10.0 * np.arange(6)]).sigma_um == pytest.approx(est.sigma_um)
    assert from_monitor([np.arange(9.0)]) is None  # too few second differences to say anything


def test_drift_at_evaluates_a_fitted_spline_and_a_constant():
    knots = [0.0, 0.0, 0.0, 0.0, 10.0, 10.0, 10.0, 10.0]
    # a cubic Bezier with equal coefficients is that constant; linear coefficients make a straight line
    np.testing.assert_allclose(drift_at({"knots_s": knots, "coefficients": [2, 2, 2, 2]}, [0, 5, 20]), 2.0)
    np.testing.assert_allclose(drift_at({"knots_s": knots, "coefficients": [0, 1, 2, 3]}, [0, 5, 10, 99]),
                               [0, 1.5, 3, 3])
    np.testing.assert_allclose(drift_at({"knots_s": None, "coefficients": [4.0]}, [1, 2]), 4.0)


def _forc_runs(t_s=None):
    model = truth_model()
    v, y, c = protocol(model, REVERSALS)
    y = y + 0.02 * np.nan_to_num(y) ** 2  # an output nonlinearity the Preisach model cannot hold
    t = np.arange(v.size, dtype=float) if t_s is None else t_s(v.size)
    runs = []
    for name, parity in (("even", 0), ("odd", 1)):
        out = np.where((c >= 0) & (c % 2 == parity), y, np.nan)
        runs.append(Run(name, v, out, t, np.full(v.size, np.nan), input_unit="T", output_unit="A m^2",
                        by_curves=True))
    return runs


@pytest.mark.slow
def test_effects_that_cannot_act_on_forc_data_are_not_applicable():
    fit, check = _forc_runs()
    d = diagnose([fit], [check], GRID)
    reasons = dict(d.not_assessed)
    assert HEATER_EFFECTS <= set(reasons) and all(reasons[e].startswith("not applicable") for e in HEATER_EFFECTS)
    assert "heater" in reasons["joule_power"] and "in T" in reasons["joule_power"]
    scored = {c.effect for c in d.candidates}
    assert "sensor_nonlinearity" in scored and not scored & HEATER_EFFECTS
    assert (d.input_unit, d.output_unit) == ("T", "A m^2")
    units = {w.by: w.unit for w in d.where}
    assert units["input_V"] == "T" and units["predicted_um"] == "A m^2" and units["reversal_V"] == "T"
    # without time stamps, the effects of time cannot act either
    fit, check = _forc_runs(lambda n: np.zeros(n))
    untimed = dict(diagnose([fit], [check], GRID).not_assessed)
    assert {"creep", "baseline_drift"} <= set(untimed) and "no time" in untimed["creep"]


@pytest.fixture
def forc_session(tmp_path):
    relays = Relays.random(40, -0.09, 0.09, seed=1, bias=0.25)
    data = forc_data(relays, REVERSALS, 0.005, 0.10, cal_drift=lambda k: 0.002 * k)
    path = write_lines(tmp_path / "d.forc", lines_0016(data))
    out = tmp_path / "d.h5"
    run = rig_here("import", "--format", "micromag", path, "--out", out, "--json")
    assert run.code == 0, run.err
    return out


@pytest.mark.slow
def test_rig_diagnose_splits_a_forc_session_into_even_and_odd_curves(forc_session, tmp_path):
    run = rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--fit-curves", "even",
                   "--check-curves", "odd", "--levels", 8, "--json", "--out", tmp_path / "fig")
    assert run.code == 0, run.err
    out = run.json()
    s = read_session(forc_session)
    odd = s.measured & (s.curves % 2 == 1)
    assert out["units"] == {"input": "T", "output": "A m^2"}
    assert out["fit"] == [f"{forc_session}:even"] and out["check"] == [f"{forc_session}:odd"]
    assert out["baseline"]["n_points"] == int(odd.sum())  # a small session: no thinning
    assert out["verdict"]["status"] in ("explained", "ambiguous", "unexplained", "no_gap")
    not_applicable = {e["effect"] for e in out["not_assessed"] if e["reason"].startswith("not applicable")}
    assert not_applicable == HEATER_EFFECTS
    assert {w["by"] for w in out["where"]} >= {"input_V", "reversal_V", "session_time_s"}
    # the grid spans the measured fields, not the saturation field
    assert (out["grid"]["v_min"], out["grid"]["v_max"]) == pytest.approx((REVERSALS.min(), 0.10))
    monitor = out["drift_monitor"]
    cal = s.calibration.output
    assert monitor["n"] == len(s.calibration) == 11
    assert monitor["measured_rms"] == pytest.approx(np.std(cal))
    assert monitor["measured_range"] == pytest.approx(np.ptp(cal))
    assert out["baseline"]["noise_source"] in ("drift_monitor", "fit_residual", "fit_residual+drift_monitor")
    assert (tmp_path / "fig" / "where.png").stat().st_size > 0
    text = rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--fit-curves", "even",
                    "--check-curves", "odd", "--levels", 8, "--stride", 2)
    assert text.code == 0, text.err
    assert "A m^2" in text.out and "Drift monitor: 11 calibration points" in text.out
    assert "one measured point in 2 of each curve" in text.out and "not applicable" in text.out


def test_rig_diagnose_refusals_on_forc_sessions(forc_session, tmp_path):
    before = forc_session.read_bytes()
    assert_one_line_error(rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--levels", 8),
                          "also an identification run")
    assert_one_line_error(rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--fit-curves",
                                   "odd", "--check-curves", "odd", "--levels", 8), "also an identification run")
    csv = write_csv(tmp_path / "t.csv", np.linspace(0, 1, 20), np.linspace(0, 1, 20))
    assert_one_line_error(rig_here("diagnose", "--fit", forc_session, "--check", csv, "--levels", 8),
                          "same units")
    assert_one_line_error(rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--fit-curves",
                                   "even", "--check-curves", "odd"), "no grid")
    assert_one_line_error(rig_here("diagnose", "--fit", forc_session, "--check", forc_session, "--fit-curves",
                                   "even", "--check-curves", "odd", "--levels", 8, "--stride", 0), "stride")
    assert forc_session.read_bytes() == before


@pytest.mark.slow
def test_rig_diagnose_on_the_shared_measurement(tmp_path):
    session = tmp_path / "md.h5"
    assert rig_here("import", "--format", "micromag", shared_forc(), "--out", session).code == 0
    run = rig_here("diagnose", "--fit", session, "--check", session, "--fit-curves", "even", "--check-curves",
                   "odd", "--levels", 12, "--stride", 100, "--json")
    assert run.code == 0, run.err
    out = run.json()
    s = read_session(session)
    odd = np.flatnonzero(s.measured & (s.curves % 2 == 1))
    # one point in 100 of every odd curve, its reversal point first
    assert out["baseline"]["n_points"] == thin_rows(s.curves, odd, 100).size
    assert out["units"] == {"input": "T", "output": "A m^2"} and out["drift_monitor"]["n"] == 297
    # no repeated runs or set-points: the calibration points give the noise, far below the model error
    assert out["baseline"]["noise_source"] == "drift_monitor"
    assert out["baseline"]["noise_floor_um"] < 0.1 * out["baseline"]["rmse_um"]
    assert {e["effect"] for e in out["not_assessed"]} == HEATER_EFFECTS
    assert out["verdict"]["status"] != "no_gap"
