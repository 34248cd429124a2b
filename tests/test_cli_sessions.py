"""``rig import`` / ``rig export`` and ``rig identify`` on sessions."""

import numpy as np
import pytest

from identify import Excitation, damped_oscillation
from identify.fit import fit_sequence
from sessions import ExcitationRecord, Quantities, SampleFlag, SessionWriter, read_session

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model, write_csv
from .test_session_files import CASES, damaged, good  # noqa: F401  (good is a fixture)


@pytest.fixture
def damped(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    v = damped_oscillation(truth.grid, thermal_term=True)
    t = 2.5 * np.arange(v.size)
    return truth, write_csv(tmp_path / "damped.csv", v, truth.predict(v), t)


def test_import_export_round_trip(damped, tmp_path):
    truth, csv = damped
    out, back = tmp_path / "s.h5", tmp_path / "back.csv"
    run = rig_here("import", csv, "--out", out, "--levels", 6, "--operator", "ada", "--json")
    assert run.code == 0, run.err
    assert run.json() == {"session": str(out), "n_samples": 23, "excitation": "damped", "levels": 6,
                          "v_min": 0.0, "v_max": 3.0, "thermal_term": True, "status": "complete",
                          "format": "csv", "n_measured": 23, "input_unit": "V", "output_unit": "um",
                          "dwell": "unknown"}
    s = read_session(out)
    v = damped_oscillation(truth.grid, thermal_term=True)
    np.testing.assert_array_equal(s.inputs, v)
    np.testing.assert_array_equal(s.outputs, truth.predict(v))
    np.testing.assert_array_equal(s.t_s, 2.5 * np.arange(23))
    assert np.all(s.samples["flags"] == SampleFlag.IMPORTED) and np.all(s.measured)
    assert s.excitation.extra["source"] == "damped.csv"
    assert s.excitation.extra["source_sha256"] == digest(csv) and s.operator == "ada"
    run = rig_here("export", out, "--csv", back)
    assert run.code == 0, run.err
    assert back.read_bytes() == csv.read_bytes()
    # neither command replaces an existing file without --force
    before = digest(out), digest(back)
    assert_one_line_error(rig_here("import", csv, "--out", out), "already exists", "--force")
    assert_one_line_error(rig_here("export", out, "--csv", back), "already exists", "--force")
    assert (digest(out), digest(back)) == before
    assert rig_here("import", csv, "--out", out, "--force").code == 0
    assert read_session(out).excitation.levels is None  # replaced: no grid this time
    assert rig_here("export", out, "--csv", back, "--force").code == 0
    assert back.read_bytes() == csv.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["back.csv", "damped.csv", "s.h5"]


def comparable(result):
    return {k: v for k, v in result.items() if k != "seconds"}


@pytest.mark.parametrize("options, stored_as", [
    (["--method", "cs_order_nn"], "cs_order_nn"),
    (["--method", "ls", "--measurements", 15, "--seed", 3], "ls-M15-s3"),
    (["--method", "ls", "--no-thermal-term", "--v-min", -0.5], "ls-r-0.5_3-nothermal"),
])
def test_identify_from_a_session_equals_identify_from_the_csv(damped, tmp_path, options, stored_as):
    _, csv = damped
    session = tmp_path / "s.h5"
    assert rig_here("import", csv, "--out", session, "-L", 6).code == 0
    from_csv = rig_here("identify", csv, "-L", 6, *options, "--json")
    from_session = rig_here("identify", session, *options, "--json")  # L from the session
    assert from_csv.code == 0 and from_session.code == 0, from_csv.err + from_session.err
    stored = from_session.json()
    assert stored.pop("name") == stored_as  # a session keeps its model, under the default name
    assert comparable(stored) == comparable(from_csv.json())
    assert set(read_session(session).models) == {stored_as}


def compressive_session(path, truth, measured_rows):
    """A damped-oscillation run that applied every point but measured only some."""
    exc = Excitation.damped(truth.grid, thermal_term=True)
    plan = np.zeros(exc.inputs.size, bool)
    plan[measured_rows] = True
    y = truth.predict(exc.inputs)
    with SessionWriter.create(path, ExcitationRecord.from_excitation(exc, measure=plan)) as w:
        for k, v in enumerate(exc.inputs):
            w.append(float(k), v, y[k], measured=bool(plan[k]), settled=bool(plan[k]), dwell_s=1.0)
    return exc.inputs, y


def test_identify_a_compressive_session_uses_measured_rows_with_full_history(tmp_path):
    truth = known_model(5, v_min=0.0, v_max=4.0)
    rng = np.random.default_rng(1)
    n = damped_oscillation(truth.grid, thermal_term=True).size
    rows = np.union1d(rng.choice(n - 1, 11, replace=False), [n - 1])
    path = tmp_path / "cs.h5"
    v, y = compressive_session(path, truth, rows)
    run = rig_here("identify", path, "--json", "--name", "ls12")
    assert run.code == 0, run.err
    out = run.json()
    assert out["n_measured"] == 12 and out["n_points"] == n and out["name"] == "ls12"
    ref = fit_sequence(truth.grid, v, np.where(np.isin(np.arange(n), rows), y, np.nan), "ls", rows=rows)
    np.testing.assert_array_equal(np.array(out["density"]), ref.model.density_matrix())
    assert out["rmse_um"] == pytest.approx(ref.rmse, abs=1e-12)
    # --measurements chooses among the measured rows only
    run = rig_here("identify", path, "--json", "-M", 6, "--seed", 4, "--name", "six")
    assert run.code == 0, run.err
    stored = read_session(path).models
    assert set(stored["six"].rows) <= set(rows) and stored["six"].rows.size == 6
    assert n - 1 in stored["six"].rows  # the thermal point is always kept
    np.testing.assert_array_equal(stored["ls12"].rows, rows)
    assert_one_line_error(rig_here("identify", path, "-M", 13), "between 1 and the 12 measured points")
    # a CSV cannot hold the unmeasured points: export says so, or drops them on request
    assert_one_line_error(rig_here("export", path, "--csv", tmp_path / "x.csv"), "--measured-only")
    assert rig_here("export", path, "--csv", tmp_path / "x.csv", "--measured-only").code == 0
    assert len((tmp_path / "x.csv").read_text().splitlines()) == 13


def test_identify_name_stores_the_model_in_the_session(damped, tmp_path):
    truth, csv = damped
    session = tmp_path / "s.h5"
    assert rig_here("import", csv, "--out", session, "-L", 6).code == 0
    run = rig_here("identify", session, "--method", "cs_order_nn", "--name", "first", "--json")
    assert run.code == 0, run.err
    rec = read_session(session).models["first"]
    np.testing.assert_allclose(rec.model.density_matrix(), truth.density_matrix(), rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(rec.model.density_matrix(), np.array(run.json()["density"]))
    assert rec.method == "cs_order_nn" and rec.metrics["n_measured"] == 23
    before = digest(session)
    assert_one_line_error(rig_here("identify", session, "--name", "first"), "already holds a model", "--force")
    assert digest(session) == before
    assert rig_here("identify", session, "--name", "first", "--force").code == 0
    assert read_session(session).models["first"].method == "ls"
    assert_one_line_error(rig_here("identify", csv, "-L", 6, "--name", "x"), "is a CSV trace")
    assert_one_line_error(rig_here("identify", session, "--name", "a/b"), "model name")


def test_session_without_a_grid_needs_levels(damped, tmp_path):
    _, csv = damped
    session = tmp_path / "s.h5"
    assert rig_here("import", csv, "--out", session).code == 0
    assert_one_line_error(rig_here("identify", session), "--levels is required", "records no grid")
    run = rig_here("identify", session, "-L", 6, "--json")
    assert run.code == 0 and run.json()["v_max"] == 3.0


def test_partial_sessions_need_partial_and_other_units_do_not_export(tmp_path):
    truth = known_model(4, v_min=0.0, v_max=2.0)
    exc = Excitation.damped(truth.grid)
    path = tmp_path / "p.h5"
    with SessionWriter.create(path, ExcitationRecord.from_excitation(exc),
                              quantities=Quantities(input_unit="T", output_unit="A m^2")) as w:
        y = truth.predict(exc.inputs)
        for k in range(8):
            w.append(float(k), exc.inputs[k], y[k])
        w.finish("aborted", "test")
    before = digest(path)
    assert_one_line_error(rig_here("identify", path, "--no-thermal-term"),
                          "partial (status aborted, 8 of 12 points applied)", "--partial")
    assert digest(path) == before
    run = rig_here("identify", path, "--no-thermal-term", "--partial", "--json")
    assert run.code == 0, run.err
    assert "partial (status aborted, 8 of 12 points applied)" in run.err
    assert digest(path) == before and "name" not in run.json()  # fitted, not stored unless named
    out = run.json()
    assert out["n_points"] == 8 and (out["input_unit"], out["output_unit"]) == ("T", "A m^2")
    assert_one_line_error(rig_here("export", path, "--csv", tmp_path / "x.csv"), "V and um only")


@pytest.mark.parametrize("case, command", [("truncated", "identify"), ("newer schema", "export"),
                                           ("not a session", "identify")])
def test_cli_reports_damaged_sessions_in_one_line(good, tmp_path, case, command):
    change, message = CASES[case]
    path = damaged(good, tmp_path, change)
    before = digest(path)
    args = ["identify", path, "--json"] if command == "identify" else ["export", path, "--csv", tmp_path / "o.csv"]
    assert_one_line_error(rig_here(*args), message)
    assert digest(path) == before and not (tmp_path / "o.csv").exists()


def test_import_force_never_replaces_an_acquisition_unless_it_is_named(tmp_path):
    """Issue 28, item 10: rig import --force replaced a session holding acquired samples, which rig acquire
    itself never does."""
    acq = tmp_path / "acq.h5"
    assert rig_here("acquire", "--levels", 3, "--dwell", 1, "--readings", 1, "--out", acq).code == 0
    truth = known_model(3, 0.0, 6.0)
    v = damped_oscillation(truth.grid, thermal_term=True)
    csv = write_csv(tmp_path / "t.csv", v, truth.predict(v))
    before = digest(acq)
    assert_one_line_error(rig_here("import", csv, "--out", acq, "--force"), "acquired sample", "--replace-session")
    assert digest(acq) == before
    assert_one_line_error(rig_here("import", csv, "--out", acq, "--replace-session", csv), "names another file")
    assert digest(acq) == before
    assert rig_here("import", csv, "--out", acq, "--replace-session", acq).code == 0
    assert read_session(acq).excitation.extra["source"] == "t.csv"


def test_export_refuses_a_value_a_csv_trace_cannot_hold(tmp_path):
    """Issue 28, item 15: rig export wrote an inf input that rig import then rejected."""
    import h5py

    acq = tmp_path / "acq.h5"
    assert rig_here("acquire", "--levels", 3, "--dwell", 1, "--readings", 1, "--out", acq).code == 0
    with h5py.File(acq, "r+") as f:
        row = f["samples"][4]
        row["input"] = np.inf
        f["samples"][4] = row
    assert_one_line_error(rig_here("export", acq, "--csv", tmp_path / "x.csv"), "row 4 has input inf")
    assert not (tmp_path / "x.csv").exists()
