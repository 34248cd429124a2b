"""Offline re-identification: rig identify on several sessions, rig validate, rig report."""

import importlib
import json
import os
import shutil
import time

import numpy as np
import pytest

from identify import Excitation, Grid, IdentifyError
from identify.model_json import model_from_dict, model_to_dict
from rig.parallel import run_parallel
from rig.reidentify import IdentifyOptions, default_model_name, fit_job, plan_jobs
from sessions import Quantities, read_session

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model
from .sessionkit import write_run


def damped_run(path, seed=0, noise=0.01, levels=6, v_max=3.0, **kwargs):
    truth = known_model(levels, v_min=0.0, v_max=v_max, seed=seed)
    write_run(path, truth, Excitation.damped(truth.grid), noise=noise, seed=seed + 100, **kwargs)
    return truth


def random_run(path, truth, n=60, seed=3, noise=0.02, grid=None, written=None, **kwargs):
    exc = Excitation.random(grid or truth.grid, n, seed=seed)
    _, y = write_run(path, truth, exc, noise=noise, seed=seed, n=written, **kwargs)
    return exc.inputs, y


def without(d, *keys):
    return {k: v for k, v in d.items() if k not in keys}


def digests(*paths):
    return [digest(p) for p in paths]


# ---------------------------------------------------------------- rig identify
def test_default_model_names():
    g = Grid(6, 0.0, 3.0)
    assert default_model_name("ls", g, levels=6, v_range=(0.0, 3.0)) == "ls"
    assert default_model_name("cs_order_nn", g, levels=6, v_range=(0.0, 3.0), measurements=15,
                              seed=3) == "cs_order_nn-M15-s3"
    assert default_model_name("ls", g, levels=8, v_range=(0.0, 3.0), thermal_term=False) == "ls-L6-nothermal"
    assert default_model_name("ls", g, levels=None, v_range=(0.0, 3.0)) == "ls-L6"  # the run records no grid
    assert default_model_name("ls", Grid(6, -0.5, 3.0), levels=6, v_range=(0.0, 3.0)) == "ls-r-0.5_3"


def test_identify_stores_the_model_by_default_and_it_round_trips(tmp_path):
    s = tmp_path / "s.h5"
    truth = damped_run(s)
    run = rig_here("identify", s, "--json", "--save", tmp_path / "m.json")
    assert run.code == 0, run.err
    out = run.json()
    assert out["name"] == "ls"
    assert json.loads((tmp_path / "m.json").read_text()) == out
    rec = read_session(s).models["ls"]
    stored = model_to_dict(rec.model)
    assert stored == {k: out[k] for k in stored}  # every model key, bit for bit through JSON
    assert rec.metrics["rmse"] == out["rmse_um"] and rec.metrics["n_measured"] == out["n_measured"] == 23
    np.testing.assert_array_equal(rec.rows, np.arange(23))
    # the stored model predicts exactly what the printed (and saved) model predicts
    v = Excitation.random(truth.grid, 80, seed=9).inputs
    np.testing.assert_array_equal(rec.model.predict(v), model_from_dict(out).predict(v))
    # the same fit again would overwrite: refused, file untouched
    before = digest(s)
    assert_one_line_error(rig_here("identify", s), "already holds a model named 'ls'", "--force", "--name")
    assert_one_line_error(rig_here("identify", s, "--name", "x", "--no-store"), "--no-store")
    run = rig_here("identify", s, "--no-store", "--json")
    assert run.code == 0 and "name" not in run.json()
    assert digest(s) == before
    run = rig_here("identify", s, "--force")
    assert run.code == 0 and "stored as /models/ls" in run.out
    events = [e.message for e in read_session(s).events if e.event == "model"]
    assert events == ["stored model ls (ls)", "replaced model ls (ls)"]


@pytest.mark.slow
def test_batch_in_parallel_gives_the_results_of_one_at_a_time(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    for k in range(3):
        damped_run(a / f"run{k}.h5", seed=k, noise=0.01 * (k + 1))
    shutil.copytree(a, b)
    options = ["--method", "ls", "-M", 18, "--seed", 2]
    batch = rig_here("identify", *[a / f"run{k}.h5" for k in range(3)], *options, "-j", 2, "--json",
                "--save", tmp_path / "models")
    assert batch.code == 0, batch.err
    out = batch.json()
    assert out["workers"] == 2 and out["seconds"] > 0 and len(out["results"]) == 3
    for k, result in enumerate(out["results"]):
        assert result["file"] == str(a / f"run{k}.h5") and result["name"] == "ls-M18-s2"
        single = rig_here("identify", b / f"run{k}.h5", *options, "--json")
        assert single.code == 0, single.err
        assert without(result, "file", "seconds") == without(single.json(), "seconds")
        saved = json.loads((tmp_path / "models" / f"run{k}.json").read_text())
        assert saved == without(result, "file")
        in_batch = read_session(a / f"run{k}.h5").models["ls-M18-s2"]
        alone = read_session(b / f"run{k}.h5").models["ls-M18-s2"]
        np.testing.assert_array_equal(in_batch.model.density, alone.model.density)
        assert (in_batch.model.mu0, in_batch.model.c_d) == (alone.model.mu0, alone.model.c_d)
        np.testing.assert_array_equal(in_batch.rows, alone.rows)
        assert without(in_batch.metrics, "seconds") == without(alone.metrics, "seconds")
    # the runs differ, so equal results are not an accident of identical inputs
    assert out["results"][0]["density"] != out["results"][1]["density"]


def test_small_batches_stay_in_one_process_unless_jobs_says_otherwise(tmp_path, monkeypatch):
    command = importlib.import_module("rig.commands.identify")  # the module, not the click command

    paths = [tmp_path / f"r{k}.h5" for k in range(2)]
    for k, p in enumerate(paths):
        damped_run(p, seed=k)
    monkeypatch.setattr(command, "default_workers", lambda n, jobs=None: 2 if jobs is None else jobs)
    run = rig_here("identify", *paths, "--no-store", "--json")
    assert run.code == 0, run.err
    assert run.json()["workers"] == 1  # two L = 6 fits: far less work than starting a pool
    assert command.batch_work(command.plan_jobs(paths, command.IdentifyOptions(store=False))) < command.PARALLEL_WORK
    monkeypatch.setattr(command, "PARALLEL_WORK", 0)  # as if the fits were large
    run = rig_here("identify", *paths, "--no-store", "--json")
    assert run.json()["workers"] == 2


def test_batch_table(tmp_path):
    paths = [tmp_path / f"r{k}.h5" for k in range(2)]
    for k, p in enumerate(paths):
        damped_run(p, seed=k)
    run = rig_here("identify", *paths, "-j", 1)
    assert run.code == 0, run.err
    lines = run.out.splitlines()
    assert lines[0].split()[:6] == ["file", "method", "L", "measured", "of", "rmse_um"]
    assert lines[2].startswith(str(paths[0])) and lines[2].endswith("/models/ls")
    assert lines[-1].startswith("2 files in") and lines[-1].endswith("on 1 process")


def test_batch_is_all_or_nothing(tmp_path):
    ok, named, aborted, rand = (tmp_path / n for n in ("ok.h5", "named.h5", "aborted.h5", "random.h5"))
    truth = damped_run(ok)
    damped_run(named, seed=1)
    assert rig_here("identify", named).code == 0
    damped_run(aborted, seed=2, n=15, status="aborted")
    random_run(rand, truth)
    files = ok, named, aborted, rand
    before = digests(*files)
    assert_one_line_error(rig_here("identify", ok, named), f"{named}: already holds a model named 'ls'")
    assert_one_line_error(rig_here("identify", ok, aborted),
                          f"{aborted}: the session is partial (status aborted, 15 of 23", "--partial")
    assert_one_line_error(rig_here("identify", ok, ok), "given twice")
    # a fit that fails in the batch (cs needs the damped oscillation) stores nothing anywhere
    assert_one_line_error(rig_here("identify", ok, rand, "--method", "cs", "-j", 1), f"{rand}:")
    assert digests(*files) == before
    # (the first 15 points of the damped oscillation are all on walls: no thermal term)
    run = rig_here("identify", ok, aborted, "--partial", "--no-thermal-term", "--json")
    assert run.code == 0, run.err
    assert f"warning: {aborted} is partial (status aborted, 15 of 23 points applied)" in run.err
    first, second = run.json()["results"]
    assert first["name"] == "ls-nothermal" and "name" not in second  # partial: stored only when named
    assert digest(aborted) == before[2] and set(read_session(ok).models) == {"ls-nothermal"}
    run = rig_here("identify", aborted, "--partial", "--no-thermal-term", "--name", "so-far")
    assert run.code == 0, run.err
    assert read_session(aborted).models["so-far"].metrics["n_measured"] == 15


def test_a_session_being_recorded(tmp_path):
    path = tmp_path / "live.h5"
    truth = known_model(6, v_min=0.0, v_max=3.0)
    writer, _ = write_run(path, truth, Excitation.damped(truth.grid), n=12, status="running")
    try:
        assert_one_line_error(rig_here("identify", path), "status running, 12 of 23 points applied, being recorded now")
        run = rig_here("identify", path, "--partial", "--no-thermal-term", "--json")
        assert run.code == 0 and run.json()["n_measured"] == 12 and "name" not in run.json()
        assert_one_line_error(rig_here("identify", path, "--partial", "--name", "x"),
                              "stored only in a finished session")
        assert read_session(path).models == {}
    finally:
        writer.finish("complete")


def job_pid(x):
    if x == "fail":
        raise IdentifyError("job says no")
    time.sleep(0.25)  # long enough that a worker started late still gets jobs (instant jobs: one took all 8)
    return x, os.getpid()


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_run_parallel_spreads_jobs_over_processes_in_order(tmp_path):
    # after this process has run the l1 solver on a problem big enough for its factorisation to
    # use its Rust thread pool (from L = 16; a plain fork copies the pool without its threads,
    # and the worker hangs) ...
    paths = [tmp_path / f"r{k}.h5" for k in range(2)]
    for k, p in enumerate(paths):
        damped_run(p, seed=k, levels=16)
    planned = plan_jobs(paths, IdentifyOptions(method="cs_order_nn", store=False))
    alone = [fit_job(j) for j in planned]
    # ... the pool still works, and gives the same fits
    pooled = run_parallel(fit_job, planned, 2, preload=["rig.reidentify"], progress=False)
    for a, b in zip(alone, pooled):
        np.testing.assert_array_equal(a.model.density, b.model.density)
        assert (a.model.mu0, a.model.c_d, a.rmse) == (b.model.mu0, b.model.c_d, b.rmse)
    jobs = list(range(8))
    results = run_parallel(job_pid, jobs, 2, progress=False)
    assert [x for x, _ in results] == jobs
    pids = {pid for _, pid in results}
    assert os.getpid() not in pids and len(pids) == 2
    assert {pid for _, pid in run_parallel(job_pid, jobs, 1, progress=False)} == {os.getpid()}
    with pytest.raises(IdentifyError, match="job says no"):
        run_parallel(job_pid, [1, "fail", 2], 2, progress=False)


# ---------------------------------------------------------------- rig validate
@pytest.fixture
def fitted(tmp_path):
    """An identified session (exact cs_order_nn model of a known truth) and a random validation run."""
    s, v = tmp_path / "s.h5", tmp_path / "v.h5"
    truth = damped_run(s, noise=0.0)
    assert rig_here("identify", s, "--method", "cs_order_nn").code == 0
    inputs, outputs = random_run(v, truth)
    return s, v, truth, inputs, outputs


def test_validate_reports_the_errors_of_the_stored_model(fitted):
    s, v, truth, inputs, outputs = fitted
    run = rig_here("validate", s, "--on", v, "--json")
    assert run.code == 0, run.err
    out = run.json()
    model = read_session(s).models["cs_order_nn"].model
    err = model.predict(inputs) - outputs
    assert out["model"] == "cs_order_nn" and out["method"] == "cs_order_nn"
    assert (out["n_points"], out["n_measured"]) == (60, 60)
    assert out["rmse"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-9)
    assert out["max_abs"] == pytest.approx(np.abs(err).max(), rel=1e-9)
    assert out["nrmse"] == pytest.approx(out["rmse"] / np.ptp(outputs), rel=1e-9)
    assert (out["input_unit"], out["output_unit"], out["levels"]) == ("V", "um", 6)
    # the model is (numerically) the truth, so what is left is the 0.02 um noise of the run
    assert 0.01 < out["rmse"] < 0.03
    run = rig_here("validate", s, "--on", v)
    assert run.code == 0 and "rmse_um" in run.out and "'cs_order_nn'" in run.out


def test_validate_uses_the_latest_model_unless_named(fitted):
    s, v, *_ = fitted
    assert rig_here("identify", s, "-M", 10, "--name", "later").code == 0
    assert rig_here("validate", s, "--on", v, "--json").json()["model"] == "later"
    assert rig_here("validate", s, "--on", v, "--model", "cs_order_nn", "--json").json()["model"] == "cs_order_nn"


def test_validate_bad_cases_change_nothing(fitted, tmp_path):
    s, v, truth, *_ = fitted
    bare, wide, tesla, part, empty = (tmp_path / f"{n}.h5" for n in ("bare", "wide", "tesla", "part", "empty"))
    damped_run(bare)
    random_run(wide, truth, grid=Grid(6, 0.0, 3.5))
    random_run(tesla, truth, quantities=Quantities(input_unit="T", output_unit="A m^2"))
    random_run(part, truth, written=40, status="aborted")
    write_run(empty, truth, Excitation.random(truth.grid, 5, seed=1), n=0, status="aborted")
    files = (s, v, bare, wide, tesla, part, empty)
    before = digests(*files)
    assert_one_line_error(rig_here("validate", bare, "--on", v), "holds no model", "rig identify")
    assert_one_line_error(rig_here("validate", s, "--model", "nope", "--on", v),
                          "no model named 'nope'", "cs_order_nn")
    assert_one_line_error(rig_here("validate", s, "--on", wide), "inputs span [0.00521529, 3.40711] V", "covers only [0, 3] V")
    assert_one_line_error(rig_here("validate", s, "--on", tesla), "records T in and A m^2 out")
    assert_one_line_error(rig_here("validate", s, "--on", empty), "holds no samples")
    assert_one_line_error(rig_here("validate", tmp_path / "missing.h5", "--on", v), "no such file")
    assert_one_line_error(rig_here("validate", s, "--on", part), "partial (status aborted, 40 of 60", "--partial")
    assert digests(*files) == before
    # a partial validation run counts only when asked for
    with_partial = rig_here("validate", s, "--on", part, "--partial", "--json")
    assert with_partial.code == 0 and with_partial.json()["n_points"] == 40
    assert digests(*files) == before
