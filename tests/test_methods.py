"""The five methods of the paper: exact recovery, constraints, and what they refuse."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identify import (
    Grid, IdentifyError, MethodNotApplicable, PreisachModel, Problem, choose_rows,
    damped_oscillation, make_method, random_input,
)
from identify.fit import fit_sequence
from identify.methods import DAMPED_METHODS

from .conftest import known_model


#: Settings for exact recovery: smooth_nn is a regularised estimator, and with
#: exactly as many rows as parameters GCV cannot tell a rough truth from
#: noise, so its penalty weight is set (near) zero here (see test_smooth_nn).
EXACT_SETTINGS = {"smooth_nn": {"weight": 1e-10}}


def relative_error(w, w_true):
    return np.linalg.norm(w - w_true) / np.linalg.norm(w_true)


@pytest.mark.parametrize("method", list(DAMPED_METHODS))
@pytest.mark.parametrize("levels,thermal", [(1, True), (5, True), (12, False), (30, True)])
def test_exact_recovery_from_all_points(method, levels, thermal):
    truth = known_model(levels, c_d=0.75 if thermal else 0.0)
    v = damped_oscillation(truth.grid, thermal)
    problem = Problem.build(truth.grid, v, truth.predict(v), thermal_term=thermal)
    fitted = make_method(method, **EXACT_SETTINGS.get(method, {})).fit(problem)
    assert relative_error(fitted.parameters_, truth.parameters(thermal)) < 1e-6
    assert fitted.model_.mu0 == pytest.approx(-1.25, rel=1e-6)


def test_least_squares_keeps_density_non_negative_and_bias_free():
    truth = known_model(6, mu0=-4.0, c_d=-2.0)
    v = random_input(truth.grid, 120, seed=1)
    rep = fit_sequence(truth.grid, v, truth.predict(v), "ls")
    assert np.all(rep.model.density >= 0)
    assert rep.model.mu0 == pytest.approx(-4.0, rel=1e-6)
    assert rep.model.c_d == pytest.approx(-2.0, rel=1e-6)


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), m=st.integers(10, 37), noise=st.floats(0.0, 3.0))
def test_cs_order_nn_never_returns_negative_density(seed, m, noise):
    rng = np.random.default_rng(seed)
    grid = Grid(8, 0.0, 1.0)
    # sparse, partly zero densities make negative CS estimates likely
    density = rng.uniform(0, 5, grid.n_cells) * (rng.random(grid.n_cells) < 0.4)
    truth = PreisachModel(grid, density, mu0=rng.normal())
    v = damped_oscillation(grid)
    y = truth.predict(v) + rng.uniform(-noise, noise, v.size)
    problem = Problem.build(grid, v, y, rows=choose_rows(v.size, m, seed), thermal_term=False)
    for name in ("cs_order_nn", "ls"):
        assert np.all(make_method(name).fit(problem).model_.density >= 0), name


def test_noise_aware_cs_respects_its_bound():
    truth = known_model(8, c_d=0.0)
    v = damped_oscillation(truth.grid)
    rng = np.random.default_rng(2)
    y = truth.predict(v) + rng.uniform(-0.5, 0.5, v.size)
    problem = Problem.build(truth.grid, v, y, rows=choose_rows(v.size, 25, 2), thermal_term=False)
    exact = make_method("cs").fit(problem)
    loose = make_method("cs", epsilon=1.0).fit(problem)
    fit = problem.measured_regressor @ loose.parameters_ - problem.measured
    assert np.linalg.norm(fit) <= 1.0 + 1e-6
    exact_fit = problem.measured_regressor @ exact.parameters_ - problem.measured
    assert np.linalg.norm(exact_fit) < 1e-6
    # the bound buys a smaller l1 norm of the DCT coefficients
    from identify.dct import dct
    assert np.abs(dct(problem.regressor @ loose.parameters_)).sum() < np.abs(
        dct(problem.regressor @ exact.parameters_)
    ).sum()


@pytest.mark.parametrize("method", ["cs", "cs_order", "cs_order_nn", "cs_nodct"])
def test_square_methods_refuse_other_designs(method):
    truth = known_model(4)
    v = random_input(truth.grid, 20, seed=0)
    problem = Problem.build(truth.grid, v, truth.predict(v))
    with pytest.raises(MethodNotApplicable, match="square"):
        make_method(method).fit(problem)
    # right length, but the thermal point on a wall: S is singular (tests/test_square_designs.py)
    v = np.append(damped_oscillation(truth.grid), truth.grid.walls[1])
    problem = Problem.build(truth.grid, v, truth.predict(v))
    with pytest.raises(MethodNotApplicable, match="invertible S.*sits on a wall"):
        make_method(method).fit(problem)


def test_order_methods_need_every_output():
    truth = known_model(4, c_d=0.0)
    v = damped_oscillation(truth.grid)
    y = truth.predict(v)
    y[::2] = np.nan  # half the points never measured
    problem = Problem.build(truth.grid, v, y, thermal_term=False)
    assert problem.order is None
    with pytest.raises(MethodNotApplicable, match="order of all"):
        make_method("cs_order").fit(problem)
    make_method("cs").fit(problem)  # plain CS only needs the measured rows


def test_thermal_term_needs_an_off_wall_measurement():
    truth = known_model(5)
    v = damped_oscillation(truth.grid, True)
    rows = np.arange(v.size - 1)  # every point but the thermal one
    problem = Problem.build(truth.grid, v, truth.predict(v), rows=rows)
    with pytest.raises(MethodNotApplicable, match="thermal term"):
        make_method("ls").fit(problem)
    # choosing M rows at random for the thermal design always keeps the thermal point
    rep = fit_sequence(truth.grid, v, truth.predict(v), "ls", measurements=5, seed=9)
    assert v.size - 1 in rep.rows and rep.n_measured == 5


def test_bad_problems():
    truth = known_model(3)
    v = damped_oscillation(truth.grid, True)
    y = truth.predict(v)
    with pytest.raises(IdentifyError, match="lengths must match"):
        Problem.build(truth.grid, v, y[:-1])
    with pytest.raises(IdentifyError, match="between 1 and N"):
        choose_rows(v.size, v.size + 1, 0)
    with pytest.raises(IdentifyError, match="between 1 and N"):
        choose_rows(v.size, 0, 0)
    with pytest.raises(IdentifyError, match="not finite"):
        Problem.build(truth.grid, np.where(np.arange(v.size) == 2, np.nan, v), y)
    with pytest.raises(IdentifyError, match="unknown method"):
        make_method("magic")


def test_rows_chosen_reproducibly():
    a, b = choose_rows(100, 30, 7), choose_rows(100, 30, 7)
    np.testing.assert_array_equal(a, b)
    assert len(set(a)) == 30 and np.all(np.diff(a) > 0)
    assert 99 in choose_rows(100, 5, 1, include=(99,))
