"""Identification from FORC data: the everett method, curve selection, and the commands on a FORC session."""

from __future__ import annotations

import numpy as np
import pytest

from identify import Grid, MethodNotApplicable, PreisachModel, damped_oscillation
from identify.fit import fit_sequence
from sessions import read_session

from .cli import assert_one_line_error, rig_here
from .conftest import write_csv
from .forcfiles import GridForcs, Relays, forc_data, lines_0016, write_lines

#: A grid whose walls fall on the even curves' reversal fields (every 0.02 T) but not the odd ones'.
GRID = Grid(9, -0.08, 0.10)
REVERSALS = np.round(np.arange(0.02, -0.0801, -0.01), 9)


def truth_model(seed: int = 4) -> PreisachModel:
    """Random weights, none above the highest reversal field (no curve reaches there)."""
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.2, 1.0, GRID.n_cells)
    d[(GRID.cell_beta >= 5) & (GRID.cell_alpha > GRID.cell_beta)] = 0.0
    return PreisachModel(GRID, d, mu0=0.5, c_d=3.0, input_unit="T", output_unit="A m^2")


def protocol(model: PreisachModel, reversals, step: float = 0.005, top: float = 0.10):
    """The FORC protocol's inputs, outputs (NaN where not measured) and curve numbers, simulated."""
    v, c = [], []
    for k, r in enumerate(reversals):
        x = np.round(r + step * np.arange(int(round((top - r) / step)) + 1), 9)
        v += [0.5, 0.12, *x]
        c += [-1, -1, *([k] * x.size)]
    v, c = np.array(v), np.array(c)
    y = model.predict(v)
    y[c < 0] = np.nan
    return v, y, c


def test_everett_recovers_a_model_from_forcs_on_the_walls():
    truth = truth_model()
    v, y, c = protocol(truth, np.round(np.arange(0.02, -0.0801, -0.02), 9))  # reversals on walls
    rep = fit_sequence(GRID, v, y, "everett", curves=c)
    np.testing.assert_allclose(rep.model.density, truth.density, rtol=0, atol=1e-9)
    assert rep.model.mu0 == pytest.approx(0.5, abs=1e-9) and rep.model.c_d == pytest.approx(3.0, abs=1e-9)
    assert rep.info["curves"] == 6 and rep.info["negative_cells"] == 0
    # the same from every other point of each curve: the walls are still among them
    rows = np.flatnonzero(np.isfinite(y) & (np.round(v / 0.01) % 2 == 0))
    rep = fit_sequence(GRID, v, y, "everett", curves=c, rows=rows)
    np.testing.assert_allclose(rep.model.density, truth.density, rtol=0, atol=1e-9)


def test_everett_says_plainly_when_it_does_not_apply():
    truth = truth_model()
    v = damped_oscillation(GRID, thermal_term=True)
    with pytest.raises(MethodNotApplicable, match="these data hold no curves"):
        fit_sequence(GRID, v, truth.predict(v), "everett")
    v, y, c = protocol(truth, [0.0, -0.04])
    top = Grid(9, -0.08, 0.6)  # above the saturation field: no curve starts from positive saturation
    with pytest.raises(MethodNotApplicable, match="does not start from positive saturation"):
        fit_sequence(top, v, y, "everett", curves=c)
    with pytest.raises(MethodNotApplicable, match="cs_order does not apply to FORC data"):
        fit_sequence(GRID, v, y, "cs_order", curves=c)


@pytest.fixture
def exact_session(tmp_path):
    """A FORC file of a grid model: even curves reverse on walls, odd curves between them."""
    data = forc_data(GridForcs(truth_model()), REVERSALS, 0.005, 0.10, {"elapsed": 400.0})
    path = write_lines(tmp_path / "grid.forc", lines_0016(data))
    out = tmp_path / "grid.h5"
    run = rig_here("import", "--format", "micromag", path, "--out", out, "--json")
    assert run.code == 0, run.err
    return out, run.json()


def test_import_identify_on_even_curves_validate_on_odd(exact_session):
    session, imported = exact_session
    assert imported["excitation"] == "forc" and imported["n_curves"] == 11 and imported["header_style"] == "0016"
    assert (imported["input_unit"], imported["output_unit"]) == ("T", "A m^2") and imported["drift_correction"] is None
    results = {}
    for method in ("everett", "ls", "smooth_nn"):
        run = rig_here("identify", session, "-L", 9, "--method", method, "--curves", "even", "--json")
        assert run.code == 0, run.err
        fit = run.json()
        # the default grid spans the measured fields, not the saturation field the protocol applied
        assert (fit["v_min"], fit["v_max"]) == (-0.08, 0.1) and fit["name"] == f"{method}-L9-even"
        assert fit["curves"] == "even" and fit["input_unit"] == "T"
        check = rig_here("validate", session, "--model", fit["name"], "--on", session, "--curves", "odd", "--json")
        assert check.code == 0, check.err
        results[method] = check.json()
    s = read_session(session)
    odd = np.flatnonzero(s.measured & (s.curves % 2 == 1))
    for method, out in results.items():
        assert {"rmse", "nrmse", "max_abs", "n"} <= set(out) and out["n"] == odd.size
        assert out["nrmse"] == pytest.approx(out["rmse"] / np.ptp(s.outputs[odd]))
        rows = s.models[f"{method}-L9-even"].rows
        assert np.all(s.curves[rows] % 2 == 0) and s.curves[rows].min() == 0  # curve 0 is even
    # the truth is on this grid: fitted on the even curves, the odd ones are predicted to the file's 7 digits,
    # which needs every odd point's memory state from its whole history
    assert results["everett"]["nrmse"] < 2e-6 and results["ls"]["nrmse"] < 2e-6
    assert results["smooth_nn"]["nrmse"] < 1e-3


def test_curve_selection_and_its_refusals(exact_session, tmp_path):
    session, _ = exact_session
    run = rig_here("identify", session, "-L", 9, "--curves", "odd", "--measurements", 40, "--seed", 2, "--json",
                   "--no-store")
    assert run.code == 0, run.err
    assert run.json()["n_measured"] == 40
    csv = write_csv(tmp_path / "t.csv", [0.0, 1.0, 0.5], [0.0, 1.0, 0.7])
    assert_one_line_error(rig_here("identify", csv, "-L", 2, "--curves", "even"), "holds no curves", "--curves even")
    assert_one_line_error(rig_here("identify", session, "-L", 9, "--curves", "odd", "--measurements", 10**6),
                          "on the odd curves")
    assert_one_line_error(rig_here("identify", session, "-L", 9, "--method", "cs", "--no-store"),
                          "cs does not apply to FORC data")
    assert_one_line_error(rig_here("identify", csv, "-L", 2, "--method", "everett"), "hold no curves")


def test_drift_correction_through_the_command(tmp_path):
    relays = Relays.random(40, -0.09, 0.09, seed=1, bias=0.25)
    data = forc_data(relays, REVERSALS, 0.005, 0.10, cal_drift=lambda k: 0.01 * k)
    path = write_lines(tmp_path / "d.forc", lines_0016(data))
    out = tmp_path / "d.h5"
    run = rig_here("import", "--format", "micromag", path, "--out", out, "--drift-correct", "offset", "--json")
    assert run.code == 0, run.err
    assert run.json()["drift_correction"]["mode"] == "offset"
    s = read_session(out)
    assert s.drift_correction["mode"] == "offset"
    rows = s.measured_rows
    drift = np.interp(s.t_s, s.calibration.t_s, s.calibration.output) - np.mean(s.calibration.output)
    np.testing.assert_allclose((s.outputs - s.samples["raw"])[rows], -drift[rows], atol=1e-12)
    assert np.ptp(drift[rows]) > 0.09
    assert_one_line_error(rig_here("import", write_csv(tmp_path / "t.csv", [0, 1], [0, 1]), "--out",
                                   tmp_path / "c.h5", "--drift-correct", "scale"), "micromag only")
    bad = write_lines(tmp_path / "bad.forc", lines_0016(data)[:80])
    assert_one_line_error(rig_here("import", "--format", "micromag", bad, "--out", tmp_path / "b.h5"),
                          "truncated")
    assert not (tmp_path / "b.h5").exists()
