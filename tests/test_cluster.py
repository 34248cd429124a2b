"""``--scheduler``: the same jobs on a dask.distributed cluster -- a scheduler and two workers on loopback --
give exactly the local results, in the same order, and a lost worker's job runs again (dask's retry).

Every process listens on 127.0.0.1 only (the dashboards too); every wait is bounded."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rig import parallel
from rig.testing import rig

from .cli import assert_one_line_error, rig_here
from .test_reident import damped_run

distributed = pytest.importorskip(
    "distributed", reason="dask.distributed is not installed: pip install -e '.[cluster]' (CI installs it)")

ROOT = Path(__file__).resolve().parents[1]
START_TIMEOUT_S = 60.0
STUDY = ("study", "--profile", "gaussian", "--levels", 8, "--measurements", 20, "--runs", 4,
         "--validation-points", 30, "--method", "ls", "--method", "cs_order_nn", "--method", "smooth_nn", "--json")


def _dask() -> str:
    exe = shutil.which("dask", path=os.path.dirname(sys.executable)) or shutil.which("dask")
    if exe is None:
        pytest.skip("the dask command is not installed beside this Python")
    return exe


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(20)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(10)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """``dask scheduler`` and two ``dask worker`` processes (one thread each) on 127.0.0.1: the address."""
    exe, where = _dask(), tmp_path_factory.mktemp("cluster")
    # the workers import the test jobs of this module (tests.test_cluster) as well as the installed packages
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    file = where / "scheduler.json"
    procs = [subprocess.Popen([exe, "scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
                               "127.0.0.1:0", "--scheduler-file", str(file)],
                              stdout=subprocess.DEVNULL, stderr=open(where / "scheduler.log", "wb"), env=env)]
    try:
        end = time.monotonic() + START_TIMEOUT_S
        while not (file.exists() and file.stat().st_size):
            assert procs[0].poll() is None, (where / "scheduler.log").read_text()
            assert time.monotonic() < end, "the scheduler did not start"
            time.sleep(0.1)
        time.sleep(0.1)  # the file is written in one go, but let it be closed
        address = json.loads(file.read_text())["address"]
        for k in range(2):
            procs.append(subprocess.Popen(
                [exe, "worker", address, "--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0",
                 "--nthreads", "1", "--nworkers", "1", "--name", f"w{k}", "--local-directory", str(where)],
                stdout=subprocess.DEVNULL, stderr=open(where / f"worker{k}.log", "wb"), env=env, cwd=where))
        with distributed.Client(address, timeout=START_TIMEOUT_S) as client:
            client.wait_for_workers(2, timeout=START_TIMEOUT_S)
        yield address
    finally:
        _stop(procs[::-1])


def _without_times(out: dict) -> dict:
    return {**out, "methods": {name: {k: v for k, v in m.items() if k != "seconds"}
                               for name, m in out["methods"].items()}}


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_study_on_the_cluster_is_the_local_study(cluster):
    local = rig_here(*STUDY, "--workers", 2)
    assert local.code == 0, local.err
    remote = rig(*STUDY, "--scheduler", cluster, timeout=180)
    assert remote.code == 0, remote.err
    assert _without_times(remote.json()) == _without_times(local.json())


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_batch_identify_on_the_cluster_is_the_local_batch(cluster, tmp_path):
    paths = [tmp_path / f"r{k}.h5" for k in range(3)]
    for k, p in enumerate(paths):
        damped_run(p, seed=k)
    args = ("identify", *paths, "--method", "smooth_nn", "--no-store", "--json")
    local = rig_here(*args, "--jobs", 2)
    remote = rig(*args, "--scheduler", cluster, timeout=180)
    assert local.code == 0 and remote.code == 0, (local.err, remote.err)
    a, b = local.json(), remote.json()
    assert [r["file"] for r in b["results"]] == [str(p) for p in paths]  # in order
    assert b["workers"] == 2
    for x, y in zip(a["results"], b["results"]):
        assert {k: v for k, v in x.items() if k != "seconds"} == {k: v for k, v in y.items() if k != "seconds"}


def square_once(job: tuple[int, str]) -> int:
    """``k * k``; job 3 first kills its worker process (the first time only: a marker file remembers)."""
    k, marker = job
    if k == 3 and not os.path.exists(marker):
        Path(marker).write_text("killed once")
        os._exit(1)  # the worker is lost, as if its machine went away
    time.sleep(0.05)
    return k * k


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_a_lost_worker_is_replaced_and_its_job_runs_again(cluster, tmp_path):
    marker = tmp_path / "killed"
    jobs = [(k, str(marker)) for k in range(8)]
    results = parallel.run_parallel(square_once, jobs, 2, progress=False, scheduler=cluster)
    assert marker.exists()  # a worker did die
    assert results == [k * k for k in range(8)]
    with distributed.Client(cluster, timeout=30) as client:
        client.wait_for_workers(2, timeout=START_TIMEOUT_S)  # the nanny started it again


def test_a_scheduler_that_does_not_answer_is_one_line_and_exit_2(monkeypatch):
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT_S", 0.5)
    assert_one_line_error(rig_here("study", "--runs", 1, "--scheduler", "tcp://127.0.0.1:9"),
                          "--scheduler tcp://127.0.0.1:9", "cannot reach a dask scheduler")
    assert_one_line_error(rig_here("study", "--runs", 1, "--scheduler", "nonsense"), "not a scheduler address")
    assert_one_line_error(rig_here("study", "--workers", 2, "--scheduler", "tcp://127.0.0.1:9"), "--workers")
    assert_one_line_error(rig_here("identify", "x.h5", "-j", 2, "--scheduler", "tcp://127.0.0.1:9"), "--jobs")
