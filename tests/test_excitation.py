import numpy as np
import pytest
import scipy.linalg

from identify import Grid, damped_oscillation, random_input, regressor_matrix, thermal_point
from identify.excitation import damped_oscillation_walls
from identify.grid import n_cells


@pytest.mark.parametrize("levels", [1, 2, 3, 4, 10, 30])
def test_damped_oscillation_shape(levels):
    k = damped_oscillation_walls(levels)
    assert k.size == n_cells(levels) + 1
    assert k[0] == levels and k[1] == levels - 1
    assert np.all(np.abs(np.diff(k)) == 1)  # one wall at a time
    # each sweep one shorter: turning points L, 0, L-1, 1, L-2, ...
    turns = [k[0]] + [k[n] for n in range(1, k.size - 1) if (k[n] - k[n - 1]) * (k[n + 1] - k[n]) < 0] + [k[-1]]
    expected = [levels]
    lo, hi = 0, levels - 1
    for n in range(len(turns) - 1):
        expected.append(lo if n % 2 == 0 else hi)
        if n % 2 == 0:
            lo += 1
        else:
            hi -= 1
    assert turns == expected


def test_small_case_by_hand():
    assert damped_oscillation_walls(1).tolist() == [1, 0]
    assert damped_oscillation_walls(2).tolist() == [2, 1, 0, 1]
    assert damped_oscillation_walls(3).tolist() == [3, 2, 1, 0, 1, 2, 1]
    g = Grid(1, 0, 1)
    # S for L = 1: [[+1, 1], [-1, 1]]
    np.testing.assert_array_equal(regressor_matrix(g, damped_oscillation(g), False), [[1, 1], [-1, 1]])


@pytest.mark.slow
def test_invertible_for_every_level_up_to_60():
    for levels in range(1, 61):
        g = Grid(levels, 0.0, 5.0)
        for thermal in (False, True):
            s = regressor_matrix(g, damped_oscillation(g, thermal), thermal)
            assert s.shape[0] == s.shape[1] == n_cells(levels) + 1 + thermal
            lu, _ = scipy.linalg.lu_factor(s)
            rcond, info = scipy.linalg.lapack.dgecon(lu, np.abs(s).sum(axis=0).max(), norm="1")
            assert info == 0 and rcond > 1e-8, (levels, thermal, rcond)


@pytest.mark.parametrize("levels", [1, 2, 3, 5])
def test_no_on_wall_thermal_point_can_work(levels):
    """Why the thermal point is off-wall: on the walls v is affine in the diagonal cells."""
    g = Grid(levels, 0.0, 5.0)
    base = damped_oscillation(g)
    for wall in g.walls:
        s = regressor_matrix(g, np.append(base, wall), True)
        assert np.linalg.matrix_rank(s) == s.shape[0] - 1


def test_thermal_point_half_a_cell_above_the_end():
    g = Grid(30, 0.0, 3.0)
    assert thermal_point(g) == pytest.approx(1.55)
    assert damped_oscillation(g, True)[-1] == thermal_point(g)


def test_random_input_is_seeded_and_in_range():
    g = Grid(10, -1.0, 2.0)
    a, b = random_input(g, 50, seed=3), random_input(g, 50, seed=3)
    np.testing.assert_array_equal(a, b)
    assert a.min() >= -1 and a.max() <= 2
    assert not np.array_equal(a, random_input(g, 50, seed=4))
