"""Any square design whose ``S`` is invertible: the square methods accept it and identify exactly.

Other damped-oscillation orderings and thermal points anywhere that keeps
``S`` invertible (off the walls, beyond the range) are accepted; a singular
design -- an on-wall thermal point, a thermal point a hair off a wall, a
repeated input -- is refused with the reason, by the fast and the dense path.
"""

import numpy as np
import pytest

from identify import Grid, MethodNotApplicable, Problem, damped_oscillation, make_method, regressor_matrix
from identify.regressor_design import SINGULAR_RCOND, Design
from identify.excitation import damped_oscillation_walls
from identify.fit import fit_sequence, measurement_rows
from identify.methods import METHODS

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model, write_csv

SQUARE_METHODS = tuple(name for name, cls in METHODS.items() if cls.needs_square)


def square_designs(grid: Grid) -> dict[str, np.ndarray]:
    """Square thermal-term designs other than the damped oscillation plus half a cell above its end."""
    L, h = grid.levels, grid.step
    top = damped_oscillation(grid)
    walls = L - damped_oscillation_walls(L)  # the damped oscillation mirrored: from the bottom up
    bottom = grid.at_walls(walls)
    return {
        "thermal point a quarter into cell 1": np.append(top, grid.v_min + 1.25 * h),
        "thermal point beyond the range, above": np.append(top, grid.v_max + 0.6),
        "thermal point beyond the range, below": np.append(top, grid.v_min - 0.6),
        "thermal point first": np.insert(top, 0, grid.v_min + 0.5 * h),
        "from the bottom, thermal point half a cell below its end": np.append(bottom, grid.v_min + (walls[-1] - 0.5) * h),
        "from the bottom, thermal point beyond the range": np.append(bottom, grid.v_max + 0.6),
    }


def test_the_square_methods_are_the_papers_four():
    assert set(SQUARE_METHODS) == {"cs", "cs_order", "cs_order_nn", "cs_nodct"}


@pytest.mark.parametrize("levels", [1, 3, 8])
@pytest.mark.parametrize("name", list(square_designs(Grid(2, 0.0, 1.0))))
def test_every_square_method_identifies_other_square_designs_exactly(name, levels):
    truth = known_model(levels, v_min=0.0, v_max=3.0, c_d=0.75)
    v = square_designs(truth.grid)[name]
    y = truth.predict(v)
    design = Design(truth.grid, v, thermal_term=True)
    assert design.is_square and design.thermal_row is not None
    for method in SQUARE_METHODS:
        fitted = make_method(method).fit(Problem.on(design, y))
        np.testing.assert_allclose(fitted.parameters_, truth.parameters(True), rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("method", SQUARE_METHODS)
def test_the_dense_reference_accepts_them_too_and_agrees(method):
    truth = known_model(4, v_min=0.0, v_max=3.0, c_d=-0.5)
    for name, v in square_designs(truth.grid).items():
        if "beyond" in name:
            continue  # the same check; two designs are enough for cvxpy's time
        problem = Problem.build(truth.grid, v, truth.predict(v))
        dense = make_method(method, solver="dense").fit(problem).parameters_
        np.testing.assert_allclose(dense, truth.parameters(True), rtol=1e-5, atol=1e-6)


def test_the_numerical_check_agrees_with_the_rank_of_the_dense_s():
    """Every variant above is invertible for L = 1..20; the same designs with the thermal point moved onto
    a wall are not, whatever the wall and the order."""
    for levels in range(1, 21):
        grid = Grid(levels, 0.0, 3.0)
        for name, v in square_designs(grid).items():
            Design(grid, v, True).square_solver  # raises when refused
            if levels <= 6:
                assert np.linalg.matrix_rank(regressor_matrix(grid, v, True)) == v.size, (levels, name)
        for wall in grid.walls[:: max(1, levels // 3)]:
            on_wall = np.append(grid.at_walls(levels - damped_oscillation_walls(levels)), wall)
            with pytest.raises(MethodNotApplicable, match="sits on a wall"):
                Design(grid, on_wall, True).square_solver


def test_the_thermal_point_is_always_measured_wherever_it_is():
    grid = Grid(6, 0.0, 3.0)
    for name, v in square_designs(grid).items():
        thermal = Design(grid, v, True).thermal_row
        assert not grid.on_walls(v[thermal]) and np.sum(~grid.on_walls(v)) == 1
        for seed in range(5):
            assert thermal in measurement_rows(grid, v, 5, seed, True)
        # so that ls can identify c_d from a few rows of them
        fit_sequence(grid, v, known_model(6, v_min=0.0, v_max=3.0).predict(v), "ls", measurements=8, seed=1)
    # not for a design without a single off-wall point, nor without the thermal term
    assert Design(grid, damped_oscillation(grid), False).thermal_row is None
    assert Design(grid, damped_oscillation(grid, True), False).thermal_row is None


@pytest.mark.parametrize("method", SQUARE_METHODS)
@pytest.mark.parametrize("solver", ["fast", "dense"])
def test_an_on_wall_thermal_point_is_refused_with_the_reason(method, solver):
    truth = known_model(5, v_min=0.0, v_max=3.0)
    v = np.append(damped_oscillation(truth.grid), truth.grid.walls[2])
    with pytest.raises(MethodNotApplicable, match=rf"^{method} needs an invertible S.*sits on a wall.*affine"):
        make_method(method, solver=solver).fit(Problem.build(truth.grid, v, truth.predict(v)))


@pytest.mark.parametrize("solver", ["fast", "dense"])
def test_a_numerically_singular_design_is_refused_with_what_it_cannot_tell_apart(solver):
    """A thermal point 1e-8 cells above a wall is off it, but no better: rcond 4e-13 at L = 30."""
    truth = known_model(30, v_min=0.0, v_max=3.0)
    g = truth.grid
    v = np.append(damped_oscillation(g), g.walls[2] + 1e-8 * g.step)
    assert not g.on_walls(v[-1])
    with pytest.raises(MethodNotApplicable, match=r"reciprocal condition number .*e-13, below 1e-12") as info:
        make_method("cs", solver=solver).fit(Problem.build(g, v, truth.predict(v)))
    if solver == "fast":  # the estimate's column names what S cannot tell apart: c_d and the diagonal
        assert str(info.value).endswith("it cannot tell apart 30 cells, mu0 and c_d")
    # a hundred times further off the wall it is (barely) invertible again
    v[-1] = g.walls[2] + 1e-6 * g.step
    assert SINGULAR_RCOND < Design(g, v, True).square_solver.reciprocal_condition()[0] < 1e-10


@pytest.mark.parametrize("solver", ["fast", "dense"])
def test_a_repeated_input_is_refused(solver):
    truth = known_model(4, c_d=0.0)
    v = damped_oscillation(truth.grid)
    v[5] = v[4]  # the same memory state twice: two equal rows
    with pytest.raises(MethodNotApplicable, match="singular"):
        make_method("cs_order_nn", solver=solver).fit(Problem.build(truth.grid, v, truth.predict(v), thermal_term=False))


def test_through_the_cli_any_invertible_square_design_is_identified_and_a_singular_one_refused(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    v = square_designs(truth.grid)["from the bottom, thermal point half a cell below its end"]
    path = write_csv(tmp_path / "bottom.csv", v, truth.predict(v))
    run = rig_here("identify", path, "--levels", 6, "--method", "cs_order_nn", "--json")
    assert run.code == 0, run.err
    out = run.json()
    np.testing.assert_allclose(out["density"], truth.density_matrix(), rtol=1e-6, atol=1e-9)
    assert out["c_d"] == pytest.approx(truth.c_d, rel=1e-6)
    # a few measurements of it: the thermal point is among them, so ls identifies c_d
    run = rig_here("identify", path, "--levels", 6, "--method", "ls", "--measurements", 9, "--json")
    assert run.code == 0, run.err
    on_wall = np.append(damped_oscillation(truth.grid), truth.grid.walls[4])
    bad = write_csv(tmp_path / "on_wall.csv", on_wall, truth.predict(on_wall))
    before = digest(bad)
    for method in SQUARE_METHODS:
        assert_one_line_error(rig_here("identify", bad, "--levels", 6, "--method", method),
                              f"{method} needs an invertible S", "sits on a wall")
    assert digest(bad) == before
