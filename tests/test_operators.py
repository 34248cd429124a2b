"""The Everett function and the matrix-free S against the dense regressor and hand values."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identify import Grid, MemoryCurve, damped_oscillation, random_input, regressor_matrix, signed_areas
from identify.everett import (
    density_from_prefix, everett, everett_table, everett_terms, everett_weights, prefix_sums,
    prefix_sums_adjoint,
)
from identify.operators import RegressorOperator


def test_everett_of_one_triangle_by_hand():
    # L = 1: one diagonal cell of weight mu; the region beta <= alpha < x, beta < y has
    # area x y - y^2 / 2 of the triangle's 1/2, so F = mu (2 x y - y^2)
    g = Grid(1, 0.0, 1.0)
    table = everett_table(g, np.array([3.0]))
    for x, y in [(1.0, 1.0), (0.5, 0.25), (0.8, 0.1), (0.3, 0.3), (1.0, 0.0)]:
        assert everett(table, x, y) == pytest.approx(3.0 * (2 * x * y - y * y), abs=1e-15)


@settings(max_examples=40, deadline=None)
@given(levels=st.integers(1, 6), seed=st.integers(0, 1000))
def test_everett_is_the_weight_of_a_one_corner_staircase(levels, seed):
    rng = np.random.default_rng(seed)
    g = Grid(levels, 0.0, float(levels))
    mu = rng.uniform(0, 1, g.n_cells)
    x = rng.uniform(0, levels)
    y = rng.uniform(0, x)
    plus = (signed_areas(g, np.array([x]), np.array([y])) + 1) / 2  # switched-up fraction per cell
    assert everett(everett_table(g, mu), x, y) == pytest.approx(plus @ mu, abs=1e-12)
    # the same point through the sparse weights the operators use
    term, column, weight = everett_weights(levels, np.array([x]), np.array([y]))
    assert weight @ prefix_sums(g, mu)[column] == pytest.approx(plus @ mu, abs=1e-12)


@pytest.mark.parametrize("levels", [1, 2, 5, 9])
def test_prefix_table_round_trip_and_adjoint(levels):
    g = Grid(levels, 0, 1)
    rng = np.random.default_rng(levels)
    mu, r = rng.normal(size=(2, g.n_cells))
    p = prefix_sums(g, mu)
    np.testing.assert_allclose(density_from_prefix(g, p), mu, atol=1e-12)
    assert p[g.cell_index(levels - 1, levels - 1)] == pytest.approx(mu.sum())
    assert prefix_sums_adjoint(g, r) @ mu == pytest.approx(r @ p)


inputs = st.lists(st.floats(-0.5, 5.5, allow_nan=False), min_size=1, max_size=30)


@settings(max_examples=60, deadline=None)
@given(
    levels=st.integers(1, 5),
    v=inputs,
    thermal=st.booleans(),
    initial=st.sampled_from(["negative", "positive"]),
    history=st.one_of(st.none(), inputs),
    on_walls=st.booleans(),
)
def test_operator_is_the_dense_regressor(levels, v, thermal, initial, history, on_walls):
    g = Grid(levels, 0.0, 5.0)
    v = np.array(v)
    if on_walls:  # the design's own inputs: exactly on the walls
        v = g.walls[np.clip(np.rint(v / g.step), 0, levels).astype(int)]
    hist = None if history is None else np.array(history)
    dense = regressor_matrix(g, v, thermal, initial, hist)
    op = RegressorOperator(g, v, thermal, initial, hist)
    rng = np.random.default_rng(len(v))
    w = rng.normal(size=dense.shape[1])
    r = rng.normal(size=dense.shape[0])
    np.testing.assert_allclose(op.matvec(w), dense @ w, atol=1e-11)
    np.testing.assert_allclose(op.rmatvec(r), dense.T @ r, atol=1e-11)
    np.testing.assert_allclose(op.dense_rows(), dense, atol=1e-12)
    rows = np.unique(rng.integers(0, len(v), size=3))
    np.testing.assert_allclose(op.dense_rows(rows), dense[rows], atol=1e-12)
    np.testing.assert_allclose(op.rows(rows).matvec(w), dense[rows] @ w, atol=1e-11)


def test_operator_on_long_input_matches_dense_and_adjoint_holds():
    g = Grid(12, -1.0, 2.0)
    v = random_input(g, 2000, seed=3)
    op = RegressorOperator(g, v, True)
    dense = regressor_matrix(g, v, True)
    rng = np.random.default_rng(0)
    w, r = rng.normal(size=op.shape[1]), rng.normal(size=op.shape[0])
    np.testing.assert_allclose(op @ w, dense @ w, atol=1e-10)
    assert (op @ w) @ r == pytest.approx(w @ op.rmatvec(r), rel=1e-12)
    W = rng.normal(size=(op.shape[1], 3))
    np.testing.assert_allclose(op.matmat(W), dense @ W, atol=1e-10)


@settings(max_examples=50, deadline=None)
@given(xs=st.lists(st.floats(-1.0, 7.0, allow_nan=False), min_size=1, max_size=60))
def test_few_everett_terms_per_input(xs):
    """Every corner is created once and removed at most once: at most ~4 terms per input."""
    g = Grid(6, 0.0, 6.0)
    sample, sign, x, y = everett_terms(MemoryCurve(6), g.coordinates(np.array(xs)))
    assert sample.size <= 4 * len(xs)
    assert np.all(y <= x + 1e-12) and np.all(np.abs(sign) == 1)


@settings(max_examples=60, deadline=None)
@given(xs=st.lists(st.floats(-1.0, 7.0, allow_nan=False), min_size=1, max_size=30))
def test_apply_reports_the_first_changed_corner(xs):
    c = MemoryCurve(6)
    for x in Grid(6, 0.0, 6.0).coordinates(np.array(xs)):
        a0, b0 = c.tail(0)
        k = c.apply(x)
        a1, b1 = c.tail(0)
        assert a1[:k] == a0[:k] and b1[:k] == b0[:k]
        assert k == len(a0) or (a1[k:], b1[k:]) != (a0[k:], b0[k:])


def test_operator_at_scale_is_cheap():
    """L = 200's 20,102-column S: the operator holds ~70k numbers where S has 4e8."""
    g = Grid(200, 0.0, 1.0)
    op = RegressorOperator(g, damped_oscillation(g, True), True)
    assert op.increments.nnz < 5 * op.shape[0]
    w = np.random.default_rng(0).normal(size=op.shape[1])
    assert np.all(np.isfinite(op @ w))
