"""``rig demo``: acquire -> identify -> diagnose -> report on the simulated rig, end to end."""

from __future__ import annotations

import pytest

import hashlib

from rig.testing import rig
from sessions import read_session

from .cli import assert_one_line_error, rig_here

METHODS = ["ls", "cs", "cs_order", "cs_order_nn", "smooth_nn"]


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_demo_acquires_identifies_diagnoses_and_reports(tmp_path):
    out = tmp_path / "demo"
    run = rig("demo", "--levels", 8, "--measurements", 30, "--strength", 0.1, "--out", out, "--json")
    assert run.code == 0, run.err
    d = run.json()
    # acquire: two complete sessions through the sequencer, the identification run is the
    # damped oscillation of L = 8 (N = 36 cells, + mu0 + the thermal point)
    fit, check = read_session(out / "fit.h5"), read_session(out / "check.h5")
    assert fit.status.value == check.status.value == "complete"
    assert d["points"] == fit.inputs.size == 38 and d["check_points"] == check.inputs.size
    assert d["sessions"] == {"fit": str(out / "fit.h5"), "check": str(out / "check.h5")}
    # identify: every method's model is stored in the identification session under its rig identify name
    assert [m["method"] for m in d["methods"]] == METHODS
    assert {m["name"] for m in d["methods"]} == set(fit.models)
    assert all(m["name"] == f"{m['method']}-M30-s0" for m in d["methods"])
    # scored on the held-out check run: least squares and ours within 2 % of the output range
    by = {m["method"]: m for m in d["methods"]}
    assert by["ls"]["validation_nrmse"] < 0.02 and by["smooth_nn"]["validation_nrmse"] < 0.02
    # diagnose: the effect switched on in the device is the one named, blind
    assert d["effect"] == "creep" and d["strength"] == 0.1
    v = d["diagnosis"]["verdict"]
    assert v["status"] == "explained" and v["effect"] == "creep" and v["shrink"] > 0.5
    # report: real PNGs and a summary that links them
    summary = (out / "report" / "report.md").read_text()
    assert d["report"] == str(out / "report" / "report.md")
    assert {p.split("/")[-1] for p in d["figures"]} >= {"where.png", "candidates.png", "loop.png", "density.png",
                                                          "validation-loop.png"}
    for p in d["figures"]:
        data = open(p, "rb").read()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        if "/report/" in p:
            assert p.split("/")[-1] in summary


@pytest.mark.slow
def test_demo_never_overwrites_an_earlier_run(tmp_path):
    out = tmp_path / "demo"
    assert rig_here("demo", "--levels", 4, "--measurements", 10, "--effect", "none", "--out", out).code == 0
    before = {p.name: _digest(p) for p in out.glob("*.h5")}
    assert_one_line_error(rig_here("demo", "--levels", 4, "--out", out), "already holds fit.h5", "nothing is overwritten")
    assert {p.name: _digest(p) for p in out.glob("*.h5")} == before
    # issue 28, item 9: a report/ or diagnosis/ the user keeps there is not written over either
    mine = tmp_path / "mine"
    (mine / "report").mkdir(parents=True)
    (mine / "report" / "report.md").write_text("my notes")
    assert_one_line_error(rig_here("demo", "--levels", 4, "--out", mine), "already holds report", "--force")
    assert (mine / "report" / "report.md").read_text() == "my notes" and not (mine / "fit.h5").exists()
    # --force replaces an earlier demo's files -- but bad input costs nothing, --force or not
    assert_one_line_error(rig_here("demo", "--levels", 4, "--measurements", 500, "--out", out, "--force"),
                          "--measurements 500")
    assert {p.name: _digest(p) for p in out.glob("*.h5")} == before
    from rig.demo_pipeline import _fresh

    assert sorted(p.name for p in _fresh(out, force=True)) == ["check.h5", "fit.h5"]
    assert_one_line_error(rig_here("demo", "--levels", 4, "--measurements", 500, "--out", tmp_path / "d2"),
                          "--measurements 500", "between 1 and the 12 points")
    assert not (tmp_path / "d2").exists()
    assert_one_line_error(rig_here("demo", "--effect", "gremlins"), "gremlins")


@pytest.mark.slow
def test_a_strength_the_device_cannot_take_is_bad_input_and_leaves_out_usable(tmp_path):
    # issue 17, finding 6: NaN was an internal error (exit 1); 1e6 left a failed session behind
    # that made every later demo refuse the same --out
    for bad in ("nan", "inf", "-1"):
        assert_one_line_error(rig_here("demo", "--strength", bad, "--out", tmp_path / "n"), "--strength")
    assert not (tmp_path / "n").exists()
    out = tmp_path / "demo"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert_one_line_error(rig_here("demo", "--levels", 4, "-M", 10, "--strength", "1e6", "--out", out),
                          "--strength 1e+06", "PSD is saturated", "nothing was kept", "smaller --strength")
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert_one_line_error(rig_here("demo", "--levels", 4, "-M", 10, "--strength", "1e6", "--out", tmp_path / "new"),
                          "nothing was kept")
    assert not (tmp_path / "new").exists()  # a directory the failed demo created goes with it
    run = rig_here("demo", "--levels", 4, "--measurements", 10, "--out", out, "--json")
    assert run.code == 0, run.err
    assert read_session(out / "fit.h5").status.value == "complete"
