"""A CSV trace's dwells: the optional ``dwell_s`` column and ``rig import --dwell-from-time``."""

import numpy as np

from identify import damped_oscillation
from sessions import read_session, read_trace

from .cli import assert_one_line_error, rig_here
from .conftest import known_model


def _write(path, t, v, y, dwell=None):
    header = "t_s,v_V,deflection_um" + (",dwell_s" if dwell is not None else "")
    rows = [f"{float(a)!r},{float(b)!r},{float(c)!r}" + (f",{float(dwell[i])!r}" if dwell is not None else "")
            for i, (a, b, c) in enumerate(zip(t, v, y))]
    path.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return path


def _runs(tmp_path, with_dwell: bool):
    """An identification trace (the damped oscillation of L = 6, 20 s apart) and a check trace of random
    inputs with dwells of 8 or 60 s, both written with or without the dwell_s column."""
    truth = known_model(6, v_min=0.0, v_max=3.0)
    v_fit = damped_oscillation(truth.grid, thermal_term=True)
    rng = np.random.default_rng(4)
    v_check = np.round(rng.uniform(0.0, 3.0, 120), 4)
    dwell_check = rng.choice([8.0, 60.0], v_check.size)
    fit_dwell = np.full(v_fit.size, 20.0)
    y_fit = truth.predict(v_fit) + rng.normal(0, 1e-3, v_fit.size)
    y_check = truth.predict(v_check) + rng.normal(0, 1e-3, v_check.size)
    fit = _write(tmp_path / "fit.csv", np.cumsum(fit_dwell), v_fit, y_fit, fit_dwell if with_dwell else None)
    check = _write(tmp_path / "check.csv", np.cumsum(dwell_check), v_check, y_check,
                   dwell_check if with_dwell else None)
    return fit, check, dwell_check


def test_a_dwell_column_is_imported_recorded_and_exported_back(tmp_path):
    _, check, dwell = _runs(tmp_path, with_dwell=True)
    out = tmp_path / "c.h5"
    run = rig_here("import", check, "--out", out, "--json")
    assert run.code == 0, run.err
    assert run.json()["dwell"] == "recorded"
    s = read_session(out)
    np.testing.assert_array_equal(s.samples["dwell_s"], dwell)
    assert s.excitation.dwell["policy"] == "recorded"
    back = tmp_path / "back.csv"
    assert rig_here("export", out, "--csv", back).code == 0
    np.testing.assert_array_equal(read_trace(back).dwell_s, dwell)


def test_dwell_from_time_is_the_time_since_the_previous_reading_and_the_assumption_is_recorded(tmp_path):
    _, check, dwell = _runs(tmp_path, with_dwell=False)
    out = tmp_path / "c.h5"
    run = rig_here("import", check, "--out", out, "--dwell-from-time", "--json")
    assert run.code == 0, run.err
    assert run.json()["dwell"] == "from_time"
    s = read_session(out)
    # the times are the cumulative dwells: the differences give them back, the first is its own time
    np.testing.assert_allclose(s.samples["dwell_s"], dwell, rtol=1e-12)
    assert s.excitation.dwell["policy"] == "from_time" and "previous reading" in s.excitation.dwell["assumption"]


def test_a_thermal_lag_is_assessed_on_traces_that_record_their_dwells_and_named_as_not_assessed_otherwise(tmp_path):
    for with_dwell in (False, True):
        fit, check, _ = _runs(tmp_path, with_dwell)
        run = rig_here("diagnose", "--fit", fit, "--check", check, "--levels", 6, "--v-min", 0, "--v-max", 3,
                       "--effects", "thermal_lag,creep", "--json")
        assert run.code == 0, run.err
        out = run.json()
        skipped = {e["effect"]: e["reason"] for e in out["not_assessed"]}
        scored = {c["effect"] for c in out["candidates"]}
        if with_dwell:
            assert "thermal_lag" in scored and "thermal_lag" not in skipped
        else:
            assert "thermal_lag" not in scored and "dwell" in skipped["thermal_lag"]
            if out["verdict"]["status"] in ("unexplained", "ambiguous", "cannot_tell"):
                assert "not assessed: thermal_lag" in out["verdict"]["reason"]


def test_bad_dwells_are_refused_naming_the_row_and_nothing_is_written(tmp_path):
    out = tmp_path / "never.h5"
    cases = {
        "negative": ("t_s,v_V,deflection_um,dwell_s\n1,0,0,1\n2,1,1,-3\n", (), ("line 3", "negative")),
        "missing": ("t_s,v_V,deflection_um,dwell_s\n1,0,0,1\n2,1,1,\n", (), ("line 3", "dwell_s")),
        "short row": ("t_s,v_V,deflection_um,dwell_s\n1,0,0,1\n2,1,1\n", (), ("line 3", "dwell_s")),
        "not finite": ("t_s,v_V,deflection_um,dwell_s\n1,0,0,1\n2,1,1,inf\n", (), ("line 3", "not finite")),
        "time goes back": ("t_s,v_V,deflection_um\n1,0,0\n3,1,1\n2,2,2\n", ("--dwell-from-time",),
                           ("reading 3", "does not increase")),
        "both": ("t_s,v_V,deflection_um,dwell_s\n1,0,0,1\n2,1,1,1\n", ("--dwell-from-time",), ("dwell_s", "one or")),
    }
    for name, (text, extra, fragments) in cases.items():
        src = tmp_path / f"{name.replace(' ', '_')}.csv"
        src.write_text(text, encoding="utf-8")
        assert_one_line_error(rig_here("import", src, "--out", out, *extra), *fragments)
        assert not out.exists(), name
