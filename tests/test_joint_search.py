"""The joint fit's grid search over an effect's settings: products without operators, the starts screened,
the steps lengthened, the jobs mapped (one after the other, in another order, or shared with a helper
process as ``rig identify`` does on two cores) -- the same fit whichever way."""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

import identify.effects.joint as joint
from identify import Grid, PreisachModel
from identify.effects import EFFECTS, make_effect
from identify.effects.compose import predict_run
from identify.everett import everett_changes, everett_increments, prefix_sums
from identify.regressor import initial_curve
from identify.runs import Run
from rig import parallel
from rig.commands import identify as identify_command
from rig.parallel import map_with_helper, open_executor

GRID = Grid(6, 0.0, 4.0)


def _run(y, v, name="sim"):
    n = v.size
    dwell = np.full(n, 10.0)
    return Run(name, v, y, np.cumsum(dwell), dwell, 4, 0.0)


def _inputs(n=300, seed=1):
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(0.0, 0.7, n)) % 8.0
    return np.where(walk > 4.0, 8.0 - walk, walk)


V = _inputs()
TRUE = PreisachModel(GRID, np.random.default_rng(7).uniform(0.1, 1.0, GRID.n_cells), mu0=0.3, c_d=-0.4)


def _interaction_run(k=0.05, source="phase", noise=0.0):
    model = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "drive": "voltage", "source": source}),))
    y = predict_run(model, _run(np.zeros(V.size), V))
    y = y + noise * np.random.default_rng(3).normal(size=y.size)
    return _run(y, V)


@pytest.mark.parametrize("seed", range(40))
def test_a_product_from_the_replays_terms_equals_the_assembled_operators(seed):
    rng = np.random.default_rng(seed)
    levels = int(rng.integers(1, 20))
    grid = Grid(levels, -1.0, 2.0)
    n = int(rng.integers(1, 300))
    # off the walls, on the walls (repeated levels), and beyond the grid at either end
    v = rng.uniform(-1.5, 2.5, n) if seed % 2 else grid.walls[rng.integers(0, levels + 1, n)]
    p = prefix_sums(grid, rng.normal(size=grid.n_cells))
    expected = everett_increments(grid, grid.coordinates(v), initial_curve(grid)) @ p
    got = everett_changes(grid, grid.coordinates(v), initial_curve(grid), p)
    assert got.dtype == np.float64 and got.shape == (n,)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * max(1.0, np.abs(expected).max()))


def test_a_product_of_no_change_is_zero_and_float():
    got = everett_changes(GRID, np.zeros(5), initial_curve(GRID), prefix_sums(GRID, np.ones(GRID.n_cells)))
    assert got.dtype == np.float64 and not got.any()


def _reversed(function, items):
    return [function(item) for item in reversed(items)][::-1]


def _in_another_process(function, items):
    """Every job in a process of the local pool (the fitter pickled there, as the helper gets it)."""
    with open_executor(1, preload=("identify.effects.joint",)) as pool:
        return list(pool.map(function, items))


def _same_fit(a, b) -> None:
    assert a.settings == b.settings
    assert [e.params for e in a.model.effects] == [e.params for e in b.model.effects]
    np.testing.assert_array_equal(a.model.density, b.model.density)
    assert (a.model.mu0, a.model.c_d, a.rmse) == (b.model.mu0, b.model.c_d, b.rmse)
    assert a.info["solves"] == b.info["solves"]  # counted wherever they ran


def test_the_grid_search_gives_the_same_fit_however_its_jobs_are_mapped():
    run = _interaction_run(noise=0.002)
    serial = joint.fit_with_effects(GRID, [run], "ls", [make_effect("interaction")])
    _same_fit(serial, joint.fit_with_effects(GRID, [run], "ls", [make_effect("interaction")], mapper=_reversed))
    _same_fit(serial, joint.fit_with_effects(GRID, [run], "ls", [make_effect("interaction")],
                                             mapper=_in_another_process))
    helped = joint.fit_with_effects(GRID, [run], "ls", [make_effect("interaction")],
                                    mapper=functools.partial(map_with_helper, preload=("identify.effects.joint",)))
    _same_fit(serial, helped)


def test_of_the_starts_of_one_setting_only_the_lowest_takes_the_search_steps(monkeypatch):
    run = _interaction_run()
    searched = []
    iterate = joint._Fitter.iterate

    def counted(self, cur, settings, max_iter=joint.MAX_ITERATIONS, halvings=joint.HALVINGS):
        if max_iter == joint.GRID_ITERATIONS:
            searched.append(dict(settings[0]))
        return iterate(self, cur, settings, max_iter, halvings)

    monkeypatch.setattr(joint._Fitter, "iterate", counted)
    fit = joint.fit_with_effects(GRID, [run], "ls", [make_effect("interaction")])
    grid = make_effect("interaction").fit_settings_grid()
    groups = {(s["drive"], s["source"], s["reference"]) for s in grid}
    assert len(grid) > len(groups)  # there are starts to screen
    assert sorted((s["drive"], s["source"], s["reference"]) for s in searched) == sorted(groups)  # one start each
    # and the truth is still found from noise-free data: the setting, k and the density
    assert (fit.settings["interaction"]["drive"], fit.settings["interaction"]["source"]) == ("voltage", "phase")
    assert fit.model.effects[0].params["k"] == pytest.approx(0.05, rel=1e-6)
    assert fit.rmse <= 1e-9 * float(np.ptp(run.outputs))


def test_a_step_that_keeps_helping_is_lengthened_and_one_that_does_not_is_not():
    """On the profile of an interaction (the linear terms re-solved at each k), the stretched step lands
    where the residual is lower than the plain step's; the plain step is kept when stretching only hurts."""
    run = _interaction_run(k=0.05)
    fitter = joint._Fitter(GRID, (run,), "ls", None, [make_effect("interaction")], True)
    settings = ({"drive": "voltage", "source": "phase"},)
    zero = fitter.state(PreisachModel(GRID, np.zeros(GRID.n_cells)), ())
    base_model, _ = fitter.solve(zero.ctx, (), ())
    base = fitter.state(base_model, ())

    def at(k):
        effect = EFFECTS["interaction"]({"k": k, "drive": "voltage", "source": "phase"})
        return fitter.begin(replace(base, effects=(effect,)), settings)

    cur, short = at(0.0), at(0.005)  # a tenth of the way to the truth
    stretched = fitter._stretch(cur, short, settings)
    assert stretched.rss < short.rss
    assert abs(stretched.effects[0].params["k"] - 0.05) < abs(short.effects[0].params["k"] - 0.05)
    exact = at(0.05)  # already at the minimum: any longer step is worse
    assert fitter._stretch(cur, exact, settings) is exact


def test_rig_identify_shares_the_search_only_where_it_pays(monkeypatch):
    started = []
    monkeypatch.setattr(parallel, "start_workers", lambda modules: started.append(tuple(modules)))
    monkeypatch.setattr(parallel, "available_cores", lambda: 2)
    monkeypatch.setattr(parallel, "other_running_tasks", lambda: 0)

    class Job:
        def __init__(self, rows, names):
            self.rows = np.arange(rows)
            self.grid = GRID
            self.effects = tuple(make_effect(n) for n in names)

    work = identify_command.SEARCH_HELPER_WORK
    settings = len(make_effect("interaction").fit_settings_grid())
    big = Job(-(-work // settings), ["interaction"])
    assert identify_command.search_mapper([big]) is not None and started == [tuple(identify_command.WORKER_MODULES)]
    assert identify_command.search_mapper([Job(work // settings - 1, ["interaction"])]) is None  # too little
    assert identify_command.search_mapper([Job(10 * work, ["joule_power"])]) is None  # no grid to search
    monkeypatch.setattr(parallel, "other_running_tasks", lambda: 1)  # the other core is busy
    assert identify_command.search_mapper([big]) is None
    monkeypatch.setattr(parallel, "available_cores", lambda: 1)
    monkeypatch.setattr(parallel, "other_running_tasks", lambda: 0)
    assert identify_command.search_mapper([big]) is None
    assert len(started) == 1
