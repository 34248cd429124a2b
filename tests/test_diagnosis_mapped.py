"""The diagnosis's candidates run through a mapper: in another order, or shared with a helper process
(:func:`rig.parallel.map_with_helper`, what ``rig diagnose`` passes on two cores) -- the same diagnosis as
one after the other here."""

from __future__ import annotations

import functools
import operator
import os
import time

import numpy as np
import pytest

from identify.diagnosis import DiagnosisSettings, diagnose
from rig.commands import diagnose as diagnose_command
from rig.diagnosis.loading import load_runs
from rig.diagnosis.simulate import SimulatedBench, simulate
from rig import parallel
from rig.parallel import map_with_helper, open_executor, other_running_tasks

PRELOAD = diagnose_command.HELPER_MODULES


def pid_when_both_took_one(path: str) -> int:
    """This process's id, once two processes have each taken an item (their ids written to ``path``)."""
    with open(path, "a", encoding="ascii") as f:
        f.write(f"{os.getpid()}\n")
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        with open(path, encoding="ascii") as f:
            if len(set(f.read().split())) >= 2:
                break
        time.sleep(0.01)
    return os.getpid()


def test_map_with_helper_is_map_in_order_and_shares_the_items(tmp_path):
    assert map_with_helper(functools.partial(operator.mul, 3), list(range(7))) == [0, 3, 6, 9, 12, 15, 18]
    assert map_with_helper(functools.partial(operator.mul, 3), [5]) == [15]
    assert map_with_helper(functools.partial(operator.mul, 3), []) == []
    pids = map_with_helper(pid_when_both_took_one, [str(tmp_path / "pids")] * 4)
    assert os.getpid() in pids and len(set(pids)) == 2  # this process and the helper both took items


def test_map_with_helper_raises_the_first_failing_item_as_the_loop_would():
    with pytest.raises(ZeroDivisionError):
        map_with_helper(functools.partial(operator.truediv, 1.0), [1.0, 2.0, 0.0, 4.0, 0.0, 8.0])


def _reversed_map(function, items):
    """A mapper that computes the items last first (and returns them in order)."""
    return [function(x) for x in reversed(list(items))][::-1]


def _all_in_another_process(function, items):
    """A mapper that computes every item in a process of the local pool."""
    with open_executor(1, preload=PRELOAD) as pool:
        return list(pool.map(function, items))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    fit, check = simulate(SimulatedBench("baseline_drift", 0.3, seed=2, levels=8, check_points=100),
                          tmp_path_factory.mktemp("mapped"))
    return load_runs([fit], [check])


def _same(a, b) -> None:
    assert a.verdict == b.verdict
    assert [c.effect for c in a.candidates] == [c.effect for c in b.candidates]
    assert a.candidates == b.candidates  # every score and fitted parameter, exactly
    assert a.not_assessed == b.not_assessed
    assert a.residual_after.keys() == b.residual_after.keys()
    for name in a.residual_after:
        np.testing.assert_array_equal(a.residual_after[name], b.residual_after[name])
    assert (a.kept is None) == (b.kept is None)
    if a.kept is not None:
        assert (a.kept.effects, a.kept.rmse_um, a.kept.params) == (b.kept.effects, b.kept.rmse_um, b.kept.params)


@pytest.mark.slow
def test_the_diagnosis_does_not_depend_on_how_its_candidates_are_mapped(runs):
    settings = DiagnosisSettings(n_boot=200)
    serial = diagnose(runs.fit, runs.check, runs.grid, settings)
    _same(serial, diagnose(runs.fit, runs.check, runs.grid, settings, mapper=_reversed_map))
    _same(serial, diagnose(runs.fit, runs.check, runs.grid, settings, mapper=_all_in_another_process))
    helped = diagnose(runs.fit, runs.check, runs.grid, settings,
                      mapper=functools.partial(map_with_helper, preload=PRELOAD))
    _same(serial, helped)


def test_rig_diagnose_shares_the_candidates_only_where_it_pays(runs, monkeypatch):
    started = []
    monkeypatch.setattr(parallel, "start_workers", lambda modules: started.append(modules))
    monkeypatch.setattr(parallel, "available_cores", lambda: 2)
    monkeypatch.setattr(parallel, "other_running_tasks", lambda: 0)
    monkeypatch.setattr(diagnose_command, "HELPER_MIN_WORK", 100 * 83)  # 100 check points, the whole library
    assert diagnose_command._candidate_mapper(runs, None) is not None and started == [PRELOAD]
    assert diagnose_command._candidate_mapper(runs, ("thermal_lag", "joule_power")) is None  # 4 settings
    monkeypatch.setattr(parallel, "available_cores", lambda: 1)  # no second core
    assert diagnose_command._candidate_mapper(runs, None) is None
    monkeypatch.setattr(parallel, "available_cores", lambda: 2)
    monkeypatch.setattr(parallel, "other_running_tasks", lambda: 1)  # the other core is busy
    assert diagnose_command._candidate_mapper(runs, None) is None
    monkeypatch.setattr(parallel, "available_cores", lambda: 4)  # but two more are free
    assert diagnose_command._candidate_mapper(runs, None) is not None
    assert len(started) == 2


def test_other_running_tasks_does_not_count_this_one():
    other = other_running_tasks()
    assert other is None or other >= 0
