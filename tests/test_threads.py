"""Small fits run on one BLAS thread unless the user chose the threads (identify.threads)."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from identify import Grid, Problem, damped_oscillation
from identify.methods.base import Method
from identify import threads


def blas_threads() -> int:
    return max(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")


class Recording(Method):
    """A method that only records the BLAS threads it was given."""

    name = "recording"

    def _solve(self, problem):
        self.threads_seen = blas_threads()
        return np.zeros(problem.n_parameters), {}


def problem(levels: int) -> Problem:
    grid = Grid(levels, 0.0, 1.0)
    v = damped_oscillation(grid, True)
    return Problem.build(grid, v, np.zeros(v.size))


@pytest.fixture
def no_user_setting(monkeypatch):
    for name in threads.USER_SETTINGS:
        monkeypatch.delenv(name, raising=False)


def test_a_small_fit_runs_on_one_thread(no_user_setting):
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == 2
        m = Recording().fit(problem(5))
        assert m.threads_seen == 1
        assert blas_threads() == 2  # restored after the fit


def test_a_large_fit_keeps_the_library_threads(no_user_setting, monkeypatch):
    monkeypatch.setattr(threads, "SMALL_PARAMETERS", 10)
    with threadpool_limits(limits=2, user_api="blas"):
        assert Recording().fit(problem(5)).threads_seen == 2  # 17 parameters > 10


def test_the_users_own_setting_is_obeyed(monkeypatch):
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    assert not threads.single_threaded(17)
    with threadpool_limits(limits=2, user_api="blas"):
        assert Recording().fit(problem(5)).threads_seen == 2


def test_limits_nest_and_unwind(no_user_setting):
    with threadpool_limits(limits=2, user_api="blas"):
        with threads.blas_threads_for(17):
            assert blas_threads() == 1
            with threads.blas_threads_for(17):
                assert blas_threads() == 1
            assert blas_threads() == 1  # the inner exit did not lift the outer limit
        assert blas_threads() == 2
        assert threads._depth == 0
