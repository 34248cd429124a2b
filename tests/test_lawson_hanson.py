"""Lawson-Hanson on products only: the same path as scipy's NNLS where the path is unique."""

import numpy as np
import pytest
import scipy.optimize

from identify import IdentifyError, Problem, damped_oscillation, make_method, random_input
from identify.fit import measurement_rows
from identify.methods import nnls
from identify.methods.lawson_hanson import lawson_hanson
from identify.operators import RegressorOperator
from rig.commands.demo import demo_truth as vo2_actuator


def dense(x_matrix, b, **kwargs):
    return lawson_hanson(lambda x: x_matrix @ x, lambda r: x_matrix.T @ r, x_matrix.shape[1], b, **kwargs)


@pytest.mark.parametrize("m,n", [(12, 30), (30, 12), (25, 25), (40, 90)])
def test_follows_scipy_on_random_problems(m, n):
    """Gaussian matrices have no ties and no dependent columns: the path is unique."""
    removed = 0
    for seed in range(25):
        rng = np.random.default_rng(seed)
        a, b = rng.normal(size=(m, n)), rng.normal(size=m)
        x_ref, _ = scipy.optimize.nnls(a, b)
        result = dense(a, b)
        np.testing.assert_allclose(result.x, x_ref, rtol=0, atol=1e-10 * max(1.0, np.abs(x_ref).max()))
        assert set(result.passive) == set(np.flatnonzero(x_ref > 0))
        removed += result.removed
    assert removed > 0 or m > n  # the inner loop (steps to the boundary, Givens downdates) was exercised


def test_a_tie_goes_to_the_first_candidate_in_lawson_hansons_order():
    """After column 2 enters, LH's zero set is ordered [1, 0, 3]: the tie between 0 and 1 goes to 1."""
    p = np.array([1.0, 1.0, 0.0, 0.0])
    u = np.array([0.3, 0.1, 1.0, 0.2])
    x_matrix = np.column_stack([u, u - p, p, [0.0, 0.0, 0.0, 1.0]])
    b = np.array([3.0, 3.0, 1.0, 0.5])
    # the gradients of columns 0 and 1 tie once p has entered (their difference is p)
    residual = b - p * (p @ b) / (p @ p)
    assert x_matrix[:, 0] @ residual == pytest.approx(x_matrix[:, 1] @ residual)
    result = dense(x_matrix, b)
    assert list(result.passive[:2]) == [2, 1]
    assert result.x[0] == 0.0 and result.x[1] > 0.0
    # with the two columns swapped, LH's order again favours position 1: now the other column
    swapped = dense(x_matrix[:, [1, 0, 2, 3]], b)
    assert swapped.x[0] == 0.0 and swapped.x[1] > 0.0
    # both are minimisers
    assert np.linalg.norm(x_matrix @ result.x - b) == pytest.approx(
        np.linalg.norm(x_matrix[:, [1, 0, 2, 3]] @ swapped.x - b), abs=1e-12)


def test_a_dependent_column_is_rejected_as_lawson_hanson_does():
    a = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0]])
    result = dense(a, np.array([2.0, 1.0, 2.0]))
    np.testing.assert_allclose(result.x, [2.0, 0.0, 1.0], atol=1e-12)
    assert result.rejected == 1


def test_the_passive_factor_respects_its_memory_budget():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 80))
    with pytest.raises(IdentifyError, match="memory budget"):
        dense(a, rng.normal(size=50), max_bytes=8 * 50 * 10)


@pytest.mark.parametrize("path", ["operator", "gram factor lh"])
@pytest.mark.parametrize("levels,points", [(8, 400), (12, 200)])
def test_operator_path_matches_the_dense_reference_on_random_inputs(monkeypatch, levels, points, path):
    """Off-wall random inputs with more rows than parameters: no ties, one path -- on the operator and on
    the Gram factor alike."""
    monkeypatch.setattr(nnls, "DENSE_LH_ENTRIES", 0)
    if path == "operator":
        monkeypatch.setattr(nnls, "GRAM_LH_ENTRIES", 0)
    truth = vo2_actuator(levels)
    v = random_input(truth.grid, points, seed=3)
    y = truth.predict(v) + np.random.default_rng(3).uniform(-0.05, 0.05, v.size)
    problem = Problem.build(truth.grid, v, y)
    fast = make_method("ls").fit(problem)
    assert fast.info_["path"] == path
    ref = make_method("ls", solver="dense").fit(problem)
    np.testing.assert_allclose(fast.parameters_, ref.parameters_, rtol=0, atol=1e-7 * np.abs(ref.parameters_).max())


def test_operator_path_on_the_damped_oscillation_is_a_basic_minimiser(monkeypatch):
    """With ties (M < P on the walls) the basic solution may differ from scipy's, the minimum may not."""
    monkeypatch.setattr(nnls, "DENSE_LH_ENTRIES", 0)
    monkeypatch.setattr(nnls, "GRAM_LH_ENTRIES", 0)
    monkeypatch.setattr(RegressorOperator, "dense_rows", None)  # the operator path builds no block
    truth = vo2_actuator(12)
    v = damped_oscillation(truth.grid, thermal_term=True)
    y = truth.predict(v) + np.random.default_rng(1).uniform(-0.025, 0.025, v.size)
    rows = measurement_rows(truth.grid, v, 45, 1, True)
    problem = Problem.build(truth.grid, v, y, rows)
    fast = make_method("ls").fit(problem)
    ref = make_method("ls", solver="dense").fit(problem)
    assert fast.info_["residual_norm"] == pytest.approx(ref.info_["residual_norm"], rel=1e-9)
    w = fast.parameters_
    assert np.all(w[: problem.n_cells] >= 0)
    basic = problem.measured_regressor[:, np.flatnonzero(w)]
    assert np.linalg.matrix_rank(basic) == basic.shape[1]  # independent passive columns
