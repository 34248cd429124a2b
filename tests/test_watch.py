"""``rig watch`` below the browser: following a session file through its life, progress and ETA, the model
so far on its worker, the HTTP server's routes and access rules, and the command's bad invocations."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from identify import Excitation, Grid
from identify.excitation import damped_oscillation
from identify.fit import fit_sequence
from rig.testing import get, wait_state, watch
from sessions import ExcitationRecord, SessionWriter, Status
from sessions.log import append_event
from sessions.records import Event, Quantities
from sessions.schema import LIBVER, SAMPLE_DTYPE
from sessions.writer import write_layout

from rig.watch.progress import planned_waits, progress
from rig.watch.refit import NO_THERMAL, RefitJob, refit
from rig.watch.worker import Worker
from rig.watch.server import Site, WatchServer
from rig.watch.tail import SessionTail
from rig.watch.watcher import SessionWatch, WatchOptions, Workers

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model
from .sessionkit import append_point, assert_rows_as_written, excitation, write_run

FIXED = {"policy": "fixed", "seconds": 10.0, "transit_s": 1.0, "readings": 4}


# ------------------------------------------------------------------ following the file
def test_tail_reads_each_flushed_row_once_and_knows_whether_the_writer_is_alive(tmp_path):
    path = tmp_path / "s.h5"
    w = SessionWriter.create(path, excitation(12))
    with SessionTail(path) as tail:
        assert tail.poll() and tail.n_samples == 0 and tail.status is Status.RUNNING and tail.writer_alive
        for k in range(7):
            append_point(w, k)
            if k % 3 == 2:  # several rows between two polls arrive together, each once
                assert tail.poll()
                assert_rows_as_written(tail.samples, k + 1)
        assert tail.poll() and tail.n_samples == 7
        assert not tail.poll()  # nothing new: nothing to redraw
        assert_rows_as_written(tail.samples, 7)
        w.finish("aborted", "stopped by the test")
        assert tail.poll()
        assert tail.status is Status.ABORTED and not tail.writer_alive and tail.generation == 1
        assert tail.events[-1].message == "stopped by the test"


def test_tail_follows_a_resumed_session_into_the_rewritten_file(tmp_path):
    path = tmp_path / "s.h5"
    w = SessionWriter.create(path, excitation(12))
    for k in range(5):
        append_point(w, k)
    w._abandon()  # the writer dies: status running, nobody holds the lock
    with SessionTail(path) as tail:
        tail.poll()
        assert tail.status is Status.RUNNING and not tail.writer_alive and tail.n_samples == 5
        old_inode = path.stat().st_ino
        w = SessionWriter.reopen(path)  # rig acquire --resume: a checked copy renamed over the file
        assert path.stat().st_ino != old_inode
        assert tail.poll()
        assert tail.generation == 2 and tail.n_samples == 5 and tail.writer_alive
        assert [e.event for e in tail.events] == ["created", "reopened"]
        for k in range(5, 12):
            append_point(w, k)
        w.finish()
        tail.poll()
        assert tail.status is Status.COMPLETE
        assert_rows_as_written(tail.samples, 12)


def test_tail_keeps_the_last_data_and_says_why_when_the_file_goes_away(tmp_path):
    path, _ = write_run(tmp_path / "s.h5", known_model(4), Excitation.random(Grid(4, 0, 5), 20, seed=1))
    with SessionTail(path) as tail:
        tail.poll()
        assert tail.n_samples == 20 and tail.error is None
        path.unlink()
        assert tail.poll()
        assert "no such file" in tail.error and tail.n_samples == 20
        path.write_text("not a session\n")
        tail.poll()
        assert "not an HDF5 file" in tail.error and tail.n_samples == 20


def _track_like_session(path: Path, n: int) -> np.ndarray:
    """A session as another producer (such as a tracking run) might write it: extra sample columns
    (target, predicted), its own excitation kind and dwell policy; the standard columns as the schema says."""
    wide = np.dtype(SAMPLE_DTYPE.descr + [("target_um", "<f8"), ("predicted_um", "<f8")])
    rng = np.random.default_rng(5)
    v = rng.uniform(0.0, 6.0, n)
    rows = np.zeros(n, wide)
    rows["index"] = np.arange(n)
    rows["t_s"] = 1.5 * np.arange(1, n + 1)
    rows["input"], rows["output"], rows["measured"] = v, known_model(6, 0, 6).predict(v), True
    rows["target_um"], rows["predicted_um"] = rows["output"] + 0.1, rows["output"] - 0.1
    record = ExcitationRecord(kind="track", inputs=np.concatenate([v, np.zeros(5)]), levels=6, v_min=0.0,
                              v_max=6.0, dwell={"policy": "track", "period_s": 1.5})
    with h5py.File(path, "w", libver=LIBVER) as f:
        write_layout(f, record, Quantities(), "", "", None, {"clock": "real"})
        del f["samples"]
        f.create_dataset("samples", data=rows, maxshape=(None,), chunks=(64,))
        append_event(f["log"], Status.RUNNING, "created", "tracking", 0)
        append_event(f["log"], Status.ABORTED, "aborted", "", n)
    return rows


def test_a_session_with_extra_columns_and_its_own_kind_is_watched_like_any_other(tmp_path):
    path = tmp_path / "track.h5"
    rows = _track_like_session(path, 40)
    workers = Workers.start(WatchOptions(method="ls"))
    try:
        watch = SessionWatch(path, WatchOptions(method="ls"), workers)
        watch.step(render=False)
        state = watch.build_state()
    finally:
        workers.close()
    np.testing.assert_array_equal(watch.tail.samples["output"], rows["output"])
    assert state["status"] == "aborted" and state["excitation"]["kind"] == "track"
    p = state["progress"]
    assert (p["n_applied"], p["n_points"], p["n_measured"]) == (40, 45, 40)
    assert p["planned_rig_time_s"] is None and p["rig_time_s"] == 60.0  # a policy rig acquire did not write
    assert state["quantities"]["output"] == "deflection (µm)"


def test_the_status_says_what_happened_to_the_run(tmp_path):
    model, exc = known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 12, seed=2)
    failed, _ = write_run(tmp_path / "f.h5", model, exc, n=7, status="failed")
    writer, _ = write_run(tmp_path / "r.h5", model, exc, n=5, status="running")
    workers = Workers.start(WatchOptions(method="ls"))
    try:
        texts = {}
        for name in ("f.h5", "r.h5"):
            watch = SessionWatch(tmp_path / name, WatchOptions(method="ls"), workers)
            watch.step(render=False)
            texts[name] = watch.build_state()
            watch.tail.close()
        writer._abandon()  # the writer dies
        watch = SessionWatch(tmp_path / "r.h5", WatchOptions(method="ls"), workers)
        watch.step(render=False)
        dead = watch.build_state()
        watch.tail.close()
    finally:
        workers.close()
    assert texts["f.h5"]["status"] == "failed" and texts["f.h5"]["status_text"] == "failed: test"
    assert texts["f.h5"]["progress"]["eta_s"] is None
    assert texts["r.h5"]["status_text"] == "running: being written now" and texts["r.h5"]["writer_alive"]
    assert dead["status"] == "running" and not dead["writer_alive"]
    assert dead["status_text"].startswith("running, but no process is writing it")


# ------------------------------------------------------------------ progress
def _samples(t_s, measured) -> np.ndarray:
    s = np.zeros(len(t_s), SAMPLE_DTYPE)
    s["index"], s["t_s"], s["measured"] = np.arange(len(t_s)), t_s, measured
    return s


def test_planned_rig_time_and_eta_hand_computed():
    # reversals at points 2 (the input turns back at 3), 4 (at 1) and 5 (the last, reached by a rise)
    rec = ExcitationRecord(kind="file", inputs=[1, 2, 3, 2, 1, 2], measure=[1, 0, 1, 0, 1, 1], dwell=FIXED)
    waits, settle, exact = planned_waits(rec)
    np.testing.assert_array_equal(waits, [10, 1, 10, 1, 10, 10])
    assert exact and settle.tolist() == [True, False, True, False, True, True]
    events = (Event(1000.0, 0, Status.RUNNING, "created", ""),)
    # three points recorded, each took its wait plus 0.5 s
    p = progress(rec, _samples([10.5, 12.0, 22.5], [1, 0, 1]), events, writer_alive=True, now_unix=1030.0)
    assert (p.n_applied, p.n_points, p.n_measured, p.n_planned_measured) == (3, 6, 2, 4)
    assert p.planned_rig_time_s == 42.0 and p.rig_time_s == 22.5 and p.fraction == 0.5
    assert p.eta_s == pytest.approx(1 + 10 + 10 + 3 * 0.5)
    assert p.wall_elapsed_s == 30.0
    # no live writer, no ETA; a finished run's wall time stops at its end
    assert progress(rec, _samples([10.5], [1]), events, writer_alive=False).eta_s is None
    done = events + (Event(1042.0, 6, Status.COMPLETE, "complete", ""),)
    assert progress(rec, _samples(np.arange(6.0), [1] * 6), done, False, now_unix=2000.0).wall_elapsed_s == 42.0


def test_a_settle_dwell_plans_an_upper_bound_and_an_unknown_policy_none():
    settle = {"policy": "settle", "condition": "rate_below", "rate_um_per_s": 0.05, "polls": 2, "max_s": 30.0,
              "poll_s": 0.5, "transit_s": 0.0, "readings": 4}
    rec = ExcitationRecord(kind="file", inputs=[1, 2, 3, 2, 1, 2], measure=[1, 0, 1, 0, 1, 1], dwell=settle)
    events = (Event(0.0, 0, Status.RUNNING, "created", ""),)
    p = progress(rec, _samples([4.0, 4.2, 10.2], [1, 0, 1]), events, writer_alive=True, now_unix=1.0)
    assert p.planned_rig_time_s == 120.0 and not p.planned_exact
    # to come: a transit (0 s planned + the 0.2 s the transit so far took beyond it) and two dwells,
    # each as long as the dwells so far (4 and 6 s: median 5)
    assert p.eta_s == pytest.approx(0.2 + 5 + 5)
    unknown = ExcitationRecord(kind="imported", inputs=[1, 2, 3, 4], dwell={"policy": "unknown"})
    p = progress(unknown, _samples([2.0, 5.0], [1, 1]), events, writer_alive=True, now_unix=1.0)
    assert p.planned_rig_time_s is None and p.eta_s == pytest.approx(2 * 2.5)


# ------------------------------------------------------------------ the model so far
def test_refit_on_a_damped_prefix_fits_without_the_thermal_term_and_says_why():
    grid = Grid(6, 0.0, 6.0)
    truth = known_model(6, 0.0, 6.0)
    v = damped_oscillation(grid, thermal_term=True)
    y = truth.predict(v)
    part = refit(RefitJob(v[:15], y[:15], 6, 0.0, 6.0, method="ls"))
    assert part.error is None and not part.thermal_term and part.note == NO_THERMAL
    ref = fit_sequence(grid, v[:15], y[:15], "ls", thermal_term=False)
    np.testing.assert_array_equal(part.prediction, ref.model.predict(v[:15]))
    assert part.rmse == ref.rmse and part.n_used == 15
    # the whole run, thermal point included: the model is recovered exactly
    whole = refit(RefitJob(v, y, 6, 0.0, 6.0, method="ls"))
    assert whole.thermal_term and whole.note == "" and whole.c_d == pytest.approx(truth.c_d, abs=1e-8)
    np.testing.assert_allclose(whole.prediction, y, rtol=0, atol=1e-8)
    pv, pu = whole.path
    assert pv.size == 1 + (v.size - 1) * 8 and np.allclose(pu[::8], y, atol=1e-8)
    # fitted points only where measured; a degenerate grid is an error on the page, not a crash
    y_part = np.where(np.arange(v.size) % 2 == 0, y, np.nan)
    assert refit(RefitJob(v, y_part, 6, 0.0, 6.0, method="ls")).n_used == (v.size + 1) // 2
    assert "v_max" in refit(RefitJob(v, y, 6, 1.0, 1.0)).error
    # an applied but unmeasured point beyond the grid (a FORC protocol's saturation field): no prediction there
    beyond = refit(RefitJob(np.append(v, 9.0), np.append(y, np.nan), 6, 0.0, 6.0, method="ls"))
    assert np.isnan(beyond.prediction[-1]) and np.all(np.isfinite(beyond.prediction[:-1]))
    pv, pu = beyond.path
    assert np.array_equal(np.isnan(pu), pv > 6.0)


def _slow_square(x: float) -> float:
    time.sleep(x)
    return x * x


def _fails(x):
    raise ValueError(f"bad job {x}")


@pytest.mark.slow
def test_the_worker_runs_one_job_at_a_time_never_waits_and_survives_its_process_dying():
    w = Worker(_slow_square, preload=("tests.test_watch",))
    try:
        assert w.result() is None and not w.busy
        assert w.submit(0.3)
        assert not w.submit(0.0)  # busy: the caller keeps its data for later, nothing is queued
        t0 = time.monotonic()
        assert w.result() is None and time.monotonic() - t0 < 0.05  # never blocks
        end = time.monotonic() + 30
        while (r := w.result()) is None:
            assert time.monotonic() < end
            time.sleep(0.01)
        assert r == pytest.approx(0.09) and not w.busy
        assert w.submit(5.0)
        os.kill(w._proc.pid, 9)  # the process dies mid-job
        end = time.monotonic() + 10
        while (r := w.result()) is None:
            assert time.monotonic() < end
            time.sleep(0.01)
        assert isinstance(r, RuntimeError) and "ended unexpectedly" in str(r)
        assert w.submit(0.0)  # started again
        while (r := w.result()) is None:
            time.sleep(0.01)
        assert r == 0.0
    finally:
        w.close()
    f = Worker(_fails, preload=("tests.test_watch",))
    try:
        f.submit(3)
        while (r := f.result()) is None:
            time.sleep(0.01)
        assert isinstance(r, RuntimeError) and "ValueError: bad job 3" in str(r)
    finally:
        f.close()


# ------------------------------------------------------------------ the HTTP server
class Served:
    """A :class:`Site` and its :class:`WatchServer` in this process, on loopback."""

    def __init__(self, target: Path, token: str | None = None, **options) -> None:
        self.workers = Workers.start(WatchOptions(**options))
        self.site = Site(target, WatchOptions(**options), self.workers, poll_s=0.1).start()
        self.server = WatchServer(self.site, "127.0.0.1", 0, token)
        self.server.loopback_only = token is None
        import threading

        self.thread = threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.05},
                                       daemon=True)
        self.thread.start()
        self.base = f"http://127.0.0.1:{self.server.port}/"

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()
        self.site.stop()
        self.workers.close()

    def __enter__(self) -> "Served":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@pytest.mark.slow
def test_the_page_its_state_and_figures_and_nothing_that_acts(tmp_path):
    path, _ = write_run(tmp_path / "s.h5", known_model(5, 0, 6), Excitation.random(Grid(5, 0, 6), 30, seed=2))
    before = digest(path)
    with Served(path, method="ls") as s:
        status, headers, body = get(s.base)
        assert status == 200 and b"<title>rig watch</title>" in body
        assert "script-src 'self'" in headers["Content-Security-Policy"]
        state = wait_state(s.base, lambda st: {"time", "loop", "model"} <= set(st["figures"]) and not st["stale"],
                           what="with every figure drawn from the newest data")
        assert state["status"] == "complete" and state["progress"]["n_applied"] == 30
        assert state["quantities"] == {"input": "heater voltage (V)", "output": "deflection (µm)",
                                       "input_unit": "V", "output_unit": "µm"}
        assert state["model"]["status"] == "fitted" and state["model"]["n_used"] == 30
        assert state["model"]["rmse"] < 1e-6  # noise-free data, more points than cells: exact
        assert state["drawn"]["time"] == state["drawn"]["loop"] == state["drawn"]["model"] == 30
        status, headers, svg = get(s.base + "figure/loop.svg")
        assert status == 200 and headers["Content-Type"] == "image/svg+xml"
        assert b"<text" in svg and "heater voltage (V)".encode() in svg and "deflection (µm)".encode() in svg
        # a long poll returns at once when a newer state exists, and waits (bounded) when none does
        t0 = time.monotonic()
        now = json.loads(get(s.base + f"api/state?after={state['version'] - 1}&wait=5")[2])
        assert now["version"] >= state["version"] and time.monotonic() - t0 < 1
        t0 = time.monotonic()
        same = json.loads(get(s.base + f"api/state?after={now['version'] + 1000}&wait=0.5")[2])
        assert 0.45 < time.monotonic() - t0 < 5 and same["version"] >= now["version"]
        assert get(s.base + "api/state?after=x")[0] == 400
        for method in ("POST", "PUT", "DELETE"):
            import urllib.request

            req = urllib.request.Request(s.base + "api/state", method=method, data=b"")
            try:
                urllib.request.urlopen(req, timeout=5)
                raise AssertionError(f"{method} was answered")
            except urllib.error.HTTPError as e:
                assert e.code == 405
        assert get(s.base + "static/watch.js")[0] == 200
        assert get(s.base + "static/../watcher.py")[0] == 404 and get(s.base + "nothing")[0] == 404
        # loopback only: a request addressed to another host name is refused (DNS rebinding)
        assert get(s.base + "api/state", headers={"Host": "attacker.example:80"})[0] == 403
        assert get(s.base + "api/state", headers={"Host": f"localhost:{s.server.port}"})[0] == 200
    assert digest(path) == before  # watching, fitting and drawing never wrote to the session


def test_with_a_token_every_request_needs_it_and_the_page_keeps_it_in_a_cookie(tmp_path):
    path, _ = write_run(tmp_path / "s.h5", known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
    with Served(path, token="s3cret-token") as s:
        status, _, body = get(s.base)
        assert status == 403 and b"Access token needed" in body
        assert get(s.base + "api/state")[0] == 403 and get(s.base + "figure/time.svg")[0] == 403
        assert get(s.base + "?token=wrong")[0] == 403
        status, headers, _ = get(s.base + "?token=s3cret-token")
        assert status == 303 and headers["Location"] == "/"  # the token leaves the address bar
        cookie = headers["Set-Cookie"]
        assert cookie.startswith("rig_watch_token=s3cret-token") and "HttpOnly" in cookie and "SameSite=Strict" in cookie
        status, _, body = get(s.base + "api/state", headers={"Cookie": cookie.split(";")[0]})
        assert status == 200 and json.loads(body)["session"] == "s.h5"
        assert get(s.base + "api/state", headers={"Cookie": "rig_watch_token=other"})[0] == 403


def test_a_session_not_yet_created_is_waited_for(tmp_path):
    path = tmp_path / "later.h5"
    with Served(path, method="ls") as s:
        state = json.loads(get(s.base + "api/state")[2])
        assert state["status"] is None and "waiting for later.h5 to be created" in state["status_text"]
        write_run(path, known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
        state = wait_state(s.base, lambda st: st["status"] == "complete", what="once the file exists")
        assert state["progress"]["n_applied"] == 10


def test_a_directory_lists_its_sessions_and_serves_each(tmp_path):
    for name, n in (("a.h5", 12), ("b.h5", 20)):
        write_run(tmp_path / name, known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), n, seed=1))
    (tmp_path / "notes.txt").write_text("not a session")
    (tmp_path / ".a.h5.rewrite").write_bytes(b"")  # a rewrite's copy in progress: not listed
    (tmp_path / "broken.h5").write_bytes(b"garbage")
    with Served(tmp_path, method="ls") as s:
        status, _, body = get(s.base)
        assert status == 200 and b"Sessions in" in body
        listing = json.loads(get(s.base + "api/sessions")[2])
        rows = {r["name"]: r for r in listing["sessions"]}
        assert set(rows) == {"a.h5", "b.h5", "broken.h5"}
        assert (rows["b.h5"]["status"], rows["b.h5"]["n_samples"], rows["b.h5"]["n_points"]) == ("complete", 20, 20)
        assert "not an HDF5 file" in rows["broken.h5"]["error"]
        assert get(s.base + "s/b.h5")[0] == 301
        state = wait_state(s.base + "s/b.h5/", lambda st: st.get("status") == "complete")
        assert state["session"] == "b.h5" and state["progress"]["n_applied"] == 20
        assert get(s.base + "s/notes.txt/api/state")[0] == 404
        assert get(s.base + "s/..%2Fx.h5/api/state")[0] == 404


# ------------------------------------------------------------------ the command
def test_bad_invocations_are_one_line_errors(tmp_path):
    assert_one_line_error(rig_here("watch", tmp_path / "nowhere" / "missing.h5"), "missing.h5", "no such file",
                          "no directory")
    bad = tmp_path / "bad.h5"
    bad.write_text("t_s,v_V\n")
    assert_one_line_error(rig_here("watch", bad), "not an HDF5 file")
    path, _ = write_run(tmp_path / "s.h5", known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
    assert_one_line_error(rig_here("watch", path, "--host", "0.0.0.0"), "not a loopback address", "--allow-remote")
    assert_one_line_error(rig_here("watch", path, "--fit", path, "--check", path), "--fit", "not both")
    assert_one_line_error(rig_here("watch", path, "--fit", tmp_path / "id.h5"), "--fit", "no such file")
    assert_one_line_error(rig_here("watch", path, "--poll", "0"), "--poll")
    assert_one_line_error(rig_here("watch", path, "--refit-every", "0"), "--refit-every")


@pytest.mark.slow
def test_the_where_bins_appear_once_the_check_run_exists(tmp_path):
    fit, check = tmp_path / "id.h5", tmp_path / "check.h5"
    assert rig_here("acquire", "--levels", 8, "--out", fit).code == 0
    with Served(fit, method="ls", check=check) as s:
        state = wait_state(s.base, lambda st: st.get("where") is not None, what="with a where entry")
        assert state["where"]["status"] == "waiting for check.h5"
        run = rig_here("acquire", "--sequence", "check", "--levels", 8, "--points", 60, "--seed", 3, "--out", check)
        assert run.code == 0, run.err
        state = wait_state(s.base, lambda st: st["where"]["status"] == "diagnosed" and "where" in st["figures"],
                           timeout=60, what="with the diagnosis drawn")
        w = state["where"]
        assert w["n_check"] == 60 and w["verdict"] in ("explained", "ambiguous", "unexplained", "no_gap")
        svg = get(s.base + "figure/where.svg")[2].decode()
        assert "Where the model misses on the check runs" in svg and "heater voltage (V)" in svg


# ---------------------------------------------------------------- issue 28: the live page under load, typos
def _status_line(port: int, request: bytes, deadline: float) -> str:
    """Send ``request`` on a fresh connection; the reply's status line, 'refused', or 'silent' at ``deadline``."""
    import socket

    try:
        with socket.create_connection(("127.0.0.1", port), timeout=max(0.1, deadline - time.monotonic())) as sock:
            sock.sendall(request)
            data = b""
            while b"\r\n" not in data and time.monotonic() < deadline:
                sock.settimeout(max(0.05, deadline - time.monotonic()))
                chunk = sock.recv(256)
                if not chunk:
                    break
                data += chunk
            return data.split(b"\r\n")[0].decode() if b"\r\n" in data else "silent"
    except (ConnectionRefusedError, ConnectionResetError):
        return "refused"
    except OSError:
        return "silent"


@pytest.mark.slow
def test_a_burst_of_200_simultaneous_requests_is_answered_within_10_s(tmp_path):
    import threading

    path, _ = write_run(tmp_path / "s.h5", known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
    with watch(path) as w:
        port = w.ready["port"]
        request = f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n".encode()
        deadline = time.monotonic() + 10.0
        answers: list[str] = []
        go = threading.Barrier(200, timeout=10)

        def one() -> None:
            go.wait()
            answers.append(_status_line(port, request, deadline))

        threads = [threading.Thread(target=one, daemon=True) for _ in range(200)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(15)
    assert len(answers) == 200 and "silent" not in answers, {a: answers.count(a) for a in set(answers)}
    assert answers.count("HTTP/1.1 200 OK") >= 190, {a: answers.count(a) for a in set(answers)}


def test_a_request_naming_two_hosts_is_a_bad_request(tmp_path):
    path, _ = write_run(tmp_path / "s.h5", known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
    with Served(path, method="ls") as s:
        port = s.server.port
        deadline = time.monotonic() + 10
        two = f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nHost: evil.example\r\nConnection: close\r\n\r\n"
        assert _status_line(port, two.encode(), deadline) == "HTTP/1.1 400 Bad Request"
        one = f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
        assert _status_line(port, one.encode(), deadline) == "HTTP/1.1 200 OK"


def test_waiting_for_a_session_that_does_not_appear_says_so_and_lists_those_that_exist(tmp_path):
    write_run(tmp_path / "run1.h5", known_model(3, 0, 6), Excitation.random(Grid(3, 0, 6), 10, seed=2))
    with watch(tmp_path / "nosuch.h5") as w:
        w.ready
        end = time.monotonic() + 15
        while "nothing has appeared" not in w.err and time.monotonic() < end:
            time.sleep(0.1)
        err = w.err
    line = next((ln for ln in err.splitlines() if "nothing has appeared" in ln), err)
    assert f"nothing has appeared at {tmp_path / 'nosuch.h5'}" in line and "run1.h5" in line, err


def test_an_ipv4_mapped_loopback_address_is_loopback():
    from drivers.net import is_loopback

    assert is_loopback("::ffff:127.0.0.1") and is_loopback("[::ffff:127.0.0.2]") and is_loopback("::1")
    assert not is_loopback("::ffff:10.0.0.1") and not is_loopback("example.org")
