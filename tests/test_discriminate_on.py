"""``rig diagnose --discriminate PLAN.csv --discriminate-on CONFIG``: the plan acquired on the rig through
``rig acquire``'s own path, into PLAN.h5, and the diagnosis run again with it as one more check run.

The runs are acquired with ``rig acquire --config`` on the simulated device (``driver = "sim"``, virtual
clock: a plan's dwells of 8 to 600 s take no wall time) with creep switched on; the library is restricted
to two candidates that each close only part of the gap (``reversible``, ``joule_power``), so the verdict is
not clear and a plan is written.  On the simulated device served over Modbus (real time, loopback) the
run is stopped by SIGTERM during its first dwell and by a link that is gone: the exit codes of ``rig
acquire`` (130, 3), the heater at 0 V.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from rig.testing import HEADER, rig_command, served
from sessions import Status, read_session

from .acquirekit import FAST_DEVICE, bench_config
from .cli import assert_one_line_error, error_lines, rig_here
from .conftest import digest

SIM = HEADER.format(driver="sim") + "[sim.effects.creep]\nstrength = 0.2\n"

#: Two candidates that each close part of the gap the creep leaves: the verdict is not clear.
UNCLEAR = ("--with", "reversible,joule_power")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The rig configuration, an identification run (L = 6) and a check run (60 points, 2 readings each)."""
    d = tmp_path_factory.mktemp("runs")
    cfg = d / "sim.toml"
    cfg.write_text(SIM)
    fit, check = d / "fit.h5", d / "check.h5"
    assert rig_here("acquire", "--config", cfg, "--levels", 6, "--out", fit).code == 0
    run = rig_here("acquire", "--config", cfg, "--sequence", "check", "--points", 60, "--levels", 6,
                   "--readings", 2, "--out", check)
    assert run.code == 0, run.err
    return cfg, fit, check


def plan_rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["v_V", "dwell_s"]
    return np.array([[float(x) for x in r] for r in rows[1:]])


def test_the_plan_is_acquired_and_the_diagnosis_judged_again(runs, tmp_path):
    cfg, fit, check = runs
    plan, session = tmp_path / "plan.csv", tmp_path / "plan.h5"
    run = rig_here("diagnose", "--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan, "--points", 40,
                   "--discriminate-on", cfg, "--json")
    assert run.code == 0, run.err
    out = json.loads(run.out)
    assert out["verdict"]["status"] in ("ambiguous", "unexplained", "cannot_tell")
    disc = out["discriminate"]
    assert (disc["plan"], disc["session"], disc["on"]) == (str(plan), str(session), str(cfg))
    rows = plan_rows(plan)
    assert 0 < len(rows) <= 40 and len(rows) == disc["points"]
    assert np.all((rows[:, 0] >= 0) & (rows[:, 0] <= 6)) and np.all(rows[:, 1] > 0)
    # the session is an acquisition like any other: every row of the plan applied and measured, with its dwell
    s = read_session(session)
    assert s.status is Status.COMPLETE and s.excitation.kind == "file"
    assert s.n_samples == len(rows) and int(s.measured.sum()) == len(rows)
    np.testing.assert_allclose(s.inputs, rows[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(s.samples["dwell_s"], rows[:, 1], rtol=0, atol=1e-9)
    assert (s.grid.levels, s.grid.v_min, s.grid.v_max) == (6, 0.0, 6.0)  # the diagnosis's grid
    assert s.excitation.dwell["readings"] == 2  # the check run's readings
    assert [e.event for e in s.events] == ["created", "saturated", "complete"]
    assert disc["acquisition"]["status"] == "complete" and disc["acquisition"]["n_measured"] == len(rows)
    # judged again with the session as one more check run
    after = disc["after"]
    assert after["verdict"]["status"] in ("explained", "ambiguous", "unexplained", "no_gap", "cannot_tell")
    assert after["check"] == [str(check), str(session)]
    assert after["baseline"]["n_points"] == out["baseline"]["n_points"] + len(rows)
    assert isinstance(disc["changed"], str) and " -> " in disc["changed"]
    # ... exactly as diagnosing both check runs by hand
    again = rig_here("diagnose", "--fit", fit, "--check", check, session, *UNCLEAR, "--json")
    assert again.code == 0, again.err
    by_hand = json.loads(again.out)
    assert by_hand["verdict"] == after["verdict"] and by_hand["baseline"] == after["baseline"]


def test_text_report_gives_both_verdicts_and_force_replaces_the_session(runs, tmp_path):
    cfg, fit, check = runs
    plan, session = tmp_path / "plan.csv", tmp_path / "plan.h5"
    args = ("diagnose", "--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan, "--points", 40,
            "--discriminate-on", cfg)
    first = rig_here(*args)
    assert first.code == 0, first.err
    created = read_session(session).events[0].t_unix
    run = rig_here(*args, "--force")
    assert run.code == 0, run.err
    lines = run.out.splitlines()
    assert sum(ln.startswith("Verdict: ") for ln in lines) == 2
    at = next(i for i, ln in enumerate(lines) if ln.startswith("after the discriminating run"))
    assert lines[at].startswith(f"after the discriminating run ({session}): ")
    assert any(ln.startswith("Verdict: ") for ln in lines[:at]) and any(ln.startswith("Verdict: ") for ln in lines[at:])
    assert any(ln.startswith(f"discriminate: wrote {plan}") and f"into {session}" in ln for ln in lines[:at])
    assert any(ln.startswith(f"{session}: complete, ") for ln in lines[:at])  # rig acquire's summary
    s = read_session(session)
    assert s.status is Status.COMPLETE and s.n_samples == len(plan_rows(plan))
    assert s.events[0].t_unix != created  # a new session, not the old one continued


def test_no_plan_no_run(runs, tmp_path):
    cfg, fit, check = runs
    plan = tmp_path / "plan.csv"
    # 10 s of rig time holds no segment of a plan: it falls short and nothing is acquired
    run = rig_here("diagnose", "--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan, "--rig-time", 10,
                   "--discriminate-on", cfg, "--json")
    assert run.code == 0, run.err
    disc = json.loads(run.out)["discriminate"]
    assert disc["plan"] is None and disc["reason"]
    assert (disc["session"], disc["acquisition"], disc["after"], disc["changed"]) == (None, None, None, None)
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    text = rig_here("diagnose", "--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan, "--rig-time", 10,
                    "--discriminate-on", cfg)
    assert text.code == 0 and "discriminate-on: nothing acquired (no plan was written)" in text.out
    assert "after the discriminating run" not in text.out and not (tmp_path / "plan.h5").exists()


def test_bad_requests_are_one_line_errors_and_touch_nothing(runs, tmp_path):
    cfg, fit, check = runs
    base = ("diagnose", "--fit", fit, "--check", check, *UNCLEAR)
    assert_one_line_error(rig_here(*base, "--discriminate-on", cfg), "--discriminate-on", "--discriminate PLAN.csv")
    # an existing session is never replaced without --force, and nothing is written
    plan, session = tmp_path / "plan.csv", tmp_path / "plan.h5"
    session.write_bytes(b"an earlier run")
    before = digest(session)
    assert_one_line_error(rig_here(*base, "--discriminate", plan, "--discriminate-on", cfg), str(session), "--force")
    assert digest(session) == before and not plan.exists()
    # the session would be the plan itself; a rig.toml that is not there
    assert_one_line_error(rig_here(*base, "--discriminate", tmp_path / "p.h5", "--discriminate-on", cfg), "p.h5")
    assert_one_line_error(rig_here(*base, "--discriminate", tmp_path / "q.csv", "--discriminate-on",
                                   tmp_path / "none.toml"), "none.toml", "no such file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.h5"]


def _diagnose_child(args, env):
    return subprocess.Popen([*rig_command(), "diagnose", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def test_on_the_served_device_sigterm_aborts_with_the_heater_off_and_a_dead_link_exits_3(runs, tmp_path):
    _, fit, check = runs
    env = {**os.environ, "RIG_DEBUG": ""}
    with served(modbus=True, **FAST_DEVICE) as bench:
        cfg = bench_config(bench, tmp_path)
        plan, session = tmp_path / "plan.csv", tmp_path / "plan.h5"
        child = _diagnose_child(["--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan, "--points", 40,
                                 "--discriminate-on", cfg, "--json"], env)
        try:
            end = time.monotonic() + 60  # the diagnosis, then the session is created and the heater saturates
            while not (session.exists() and bench.journal.setpoints):
                assert child.poll() is None, child.communicate()
                assert time.monotonic() < end, "the discriminating run did not start within 60 s"
                time.sleep(0.05)
            time.sleep(0.3)  # inside the first dwell (20 s at 0 V: negative saturation)
            child.send_signal(signal.SIGTERM)
            out, err = child.communicate(timeout=30)
        finally:
            if child.poll() is None:
                child.kill()
                child.communicate()
        assert child.returncode == 130, err
        assert bench.device.applied_voltage == 0.0 and bench.journal.setpoints[-1].volts == 0.0
        s = read_session(session)
        assert s.status is Status.ABORTED and s.n_samples == 0
        assert f"rig acquire --resume {session}" in err and "Traceback" not in err
        disc = json.loads(out)["discriminate"]  # the first diagnosis, and what became of the run
        assert disc["session"] == str(session) and disc["acquisition"]["status"] == "aborted"
        assert disc["after"] is None and disc["changed"] is None
    # the bench is gone: the link fails before anything is driven, exit 3 as for rig acquire
    plan2 = tmp_path / "plan2.csv"
    child = _diagnose_child(["--fit", fit, "--check", check, *UNCLEAR, "--discriminate", plan2, "--points", 40,
                             "--discriminate-on", cfg], env)
    try:
        out, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
    assert child.returncode == 3, err
    assert len(error_lines(err)) == 1 and "Traceback" not in err
    assert plan2.exists() and "Verdict: " in out  # the first report was given before the run was tried
