"""The square damped-oscillation design: sparse solve and explicit sparse inverse."""

import numpy as np
import pytest
import scipy.sparse

from identify import Grid, IdentifyError, damped_oscillation, random_input, regressor_matrix
from identify.operators import RegressorOperator
from identify.excitation import damped_oscillation_walls
from identify.square import SquareSolver, sparse_inverse


@pytest.mark.parametrize("levels", [1, 2, 3, 4, 7, 12, 20])
@pytest.mark.parametrize("thermal", [False, True])
def test_sparse_solves_and_inverse_match_the_dense_inverse(levels, thermal):
    g = Grid(levels, 0.0, 5.0)
    v = damped_oscillation(g, thermal)
    dense_inv = np.linalg.inv(regressor_matrix(g, v, thermal))
    solver = SquareSolver(RegressorOperator(g, v, thermal))
    b = np.random.default_rng(levels).normal(size=(v.size, 2))
    scale = np.abs(dense_inv).max()
    np.testing.assert_allclose(solver.solve(b), dense_inv @ b, atol=1e-11 * scale)
    np.testing.assert_allclose(solver.solve_transpose(b), dense_inv.T @ b, atol=1e-11 * scale)
    inverse = solver.inverse
    assert isinstance(inverse, scipy.sparse.csr_array)
    np.testing.assert_allclose(inverse.toarray(), dense_inv, atol=1e-11 * scale)
    # at most four outputs per cell weight, six with the thermal term (Proposition 1's structure)
    assert np.diff(inverse.indptr).max() <= (6 if thermal else 4)


def test_sparse_inverse_at_l60_inverts_the_operator():
    g = Grid(60, 0.0, 1.0)
    op = RegressorOperator(g, damped_oscillation(g, True), True)
    inverse = sparse_inverse(SquareSolver(op))
    x = np.random.default_rng(1).normal(size=(op.shape[0], 2))
    np.testing.assert_allclose(inverse @ (op @ x), x, atol=1e-8)
    np.testing.assert_allclose(op @ (inverse @ x), x, atol=1e-8)
    assert inverse.nnz < 5 * op.shape[0]


def test_sparse_inverse_of_another_square_design_falls_back_to_solves():
    """Not the damped oscillation: no wall steps to pair, every row by transposed solve."""
    g = Grid(3, 0.0, 1.0)
    v = np.concatenate([random_input(g, g.n_cells + 1, seed=4)])
    dense = regressor_matrix(g, v, False)
    op = RegressorOperator(g, v, False)
    inverse = sparse_inverse(SquareSolver(op))
    np.testing.assert_allclose(inverse.toarray() @ dense, np.eye(v.size), atol=1e-8)


def test_singular_square_design_is_refused():
    g = Grid(2, 0.0, 1.0)
    v = g.walls[[2, 2, 2, 2]]  # repeating one input: every row the same
    with pytest.raises(IdentifyError, match="singular"):
        SquareSolver(RegressorOperator(g, v, False))
    with pytest.raises(IdentifyError, match="square"):
        SquareSolver(RegressorOperator(g, v[:3], False))


@pytest.mark.parametrize("levels", [2, 5, 12])
def test_condition_estimate_bounds_the_true_one_without_the_dense_matrix(levels):
    """1 / (||S||_1 ||S^-1||_1) from a few sparse solves, as LAPACK's dgecon does from a dense LU: never
    below the true value and at most twice it, on the damped oscillation, with a
    thermal point elsewhere, beyond the range (||v||_1 > n: the thermal column sets ||S||_1), and on
    the damped oscillation started from the bottom."""
    g = Grid(levels, 0.0, 5.0)
    base = damped_oscillation(g)
    designs = [(base, False), (damped_oscillation(g, True), True),
               (np.append(base, g.v_min + 0.3 * g.step), True), (np.append(base, g.v_max + 40.0), True),
               (np.append(g.at_walls(levels - damped_oscillation_walls(levels)), g.v_min + 0.5 * g.step), True)]
    state = np.random.get_state()[1].copy()
    for v, thermal in designs:
        solver = SquareSolver(RegressorOperator(g, v, thermal))
        rcond, column = solver.reciprocal_condition()
        dense = regressor_matrix(g, v, thermal)
        inverse = np.linalg.inv(dense)
        exact = 1 / (np.abs(dense).sum(axis=0).max() * np.abs(inverse).sum(axis=0).max())
        assert exact * (1 - 1e-9) <= rcond <= 2 * exact
        # the column returned is a column of S^{-1}, the one whose 1-norm is the estimate
        k = int(np.argmin(np.abs(inverse - column[:, None]).sum(axis=0)))
        np.testing.assert_allclose(column, inverse[:, k], atol=1e-9 * np.abs(inverse).max())
        assert np.abs(column).sum() == pytest.approx(1 / (rcond * max(v.size, np.abs(v).sum() if thermal else 0)))
    assert np.array_equal(np.random.get_state()[1], state)  # deterministic: numpy's global generator untouched
