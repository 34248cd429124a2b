"""The Gram matrix from the sparse memory states, and Lawson-Hanson on its factor, against dense references."""

import numpy as np
import pytest
import scipy.optimize

from identify import Grid, MemoryCurve, Problem, make_method, random_input
from identify.everett import everett_terms
from identify.methods import nnls
from identify.operators import AugmentedOperator, RegressorOperator, RowScaledOperator
from identify.regressor_design import Design
from rig.commands.demo import demo_truth as vo2_actuator


def noisy_reversals(grid: Grid, n: int, seed: int) -> np.ndarray:
    """Rising and falling sweeps with small noisy reversals (a memory of many short-lived corners), beyond
    the walls now and then (saturation), like the hysterons' input of a fit with mean-field feedback."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 6.0 * np.pi, n)
    span = grid.v_max - grid.v_min
    sweep = 0.5 * (grid.v_min + grid.v_max) + 0.6 * span * np.sin(t) * np.exp(-t / 20.0)
    return sweep + 0.03 * span * rng.normal(size=n)


def dense_gram(op, rows):
    a = op.dense_rows(rows)
    return a.T @ a


@pytest.mark.parametrize("levels,n,seed", [(3, 60, 0), (7, 400, 1), (12, 900, 2)])
def test_states_are_the_running_sums_of_the_increments(levels, n, seed):
    grid = Grid(levels, 0.0, 1.0)
    op = RegressorOperator(grid, noisy_reversals(grid, n, seed), False)
    rows = np.sort(np.random.default_rng(seed).choice(n, n // 2, replace=False))
    dense = np.cumsum(op.increments.toarray(), axis=0)[rows]
    np.testing.assert_allclose(op.states(rows).toarray(), dense, rtol=0, atol=1e-12)


@pytest.mark.parametrize("thermal", [False, True])
@pytest.mark.parametrize("levels,n,seed", [(4, 80, 3), (9, 600, 4)])
def test_gram_equals_the_dense_products(levels, n, seed, thermal):
    rng = np.random.default_rng(seed)
    grid = Grid(levels, -1.0, 2.0)
    v = noisy_reversals(grid, n, seed)
    rows = np.sort(rng.choice(n, 2 * n // 3, replace=False))
    base = RegressorOperator(grid, v, thermal)
    extra, penalty = rng.normal(size=(n, 3)), rng.normal(size=(2, 3))
    aug = AugmentedOperator(base, extra, 2, penalty)
    with_penalty = np.concatenate([rows, [n, n + 1]])
    scaled = RowScaledOperator(aug, rng.uniform(0.5, 1.5, n + 2))
    for op, r in [(base, rows), (aug, with_penalty), (scaled, with_penalty), (RowScaledOperator(base, rng.uniform(0.5, 2, n)), rows)]:
        ref = dense_gram(op, r)
        np.testing.assert_allclose(op.gram(r), ref, rtol=0, atol=1e-11 * np.abs(ref).max())


@pytest.mark.parametrize("levels,points,seed", [(6, 300, 5), (9, 500, 6)])
def test_lawson_hanson_on_the_gram_factor_follows_scipy_on_a_tall_problem(monkeypatch, levels, points, seed):
    """Off-wall random inputs, more rows than parameters: the minimiser is unique and every path finds it --
    the factor's Lawson-Hanson, the operator's, and scipy's NNLS on the dense rows."""
    monkeypatch.setattr(nnls, "DENSE_LH_ENTRIES", 0)
    truth = vo2_actuator(levels)
    v = random_input(truth.grid, points, seed=seed)
    y = truth.predict(v) + np.random.default_rng(seed).uniform(-0.05, 0.05, v.size)
    problem = Problem.build(truth.grid, v, y)
    a = problem.measured_regressor
    assert np.linalg.matrix_rank(a) == a.shape[1]  # full column rank: one minimiser
    factor, info = nnls.nnls_operator(problem.operator, problem.rows, problem.measured, problem.n_nonneg)
    assert info["path"] == "gram factor lh"
    monkeypatch.setattr(nnls, "GRAM_LH_ENTRIES", 0)
    operator, info = nnls.nnls_operator(problem.operator, problem.rows, problem.measured, problem.n_nonneg)
    assert info["path"] == "operator"
    reference, _ = nnls.nnls_free(a, problem.measured, problem.n_nonneg)
    scale = np.abs(reference).max()
    np.testing.assert_allclose(factor, reference, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(factor, operator, rtol=0, atol=1e-8 * scale)
    # the free split columns: the same non-negative problem straight through scipy
    split = np.hstack([a, -a[:, problem.n_nonneg:]])
    x, _ = scipy.optimize.nnls(split, problem.measured)
    direct = x[: a.shape[1]].copy()
    direct[problem.n_nonneg:] -= x[a.shape[1]:]
    np.testing.assert_allclose(factor, direct, rtol=0, atol=1e-8 * scale)


def test_a_method_reaches_the_factor_path_above_the_dense_budget(monkeypatch):
    monkeypatch.setattr(nnls, "DENSE_LH_ENTRIES", 0)
    monkeypatch.setattr(RegressorOperator, "dense_rows", None)  # the factor path builds no block of S
    truth = vo2_actuator(8)
    v = random_input(truth.grid, 400, seed=9)
    problem = Problem.build(truth.grid, v, truth.predict(v))
    fit = make_method("ls").fit(problem)
    assert fit.info_["path"] == "gram factor lh"
    assert fit.info_["residual_norm"] < 1e-8 * np.linalg.norm(problem.measured)


def test_everett_terms_moves_the_curve_as_a_replay_does():
    grid = Grid(10, 0.0, 1.0)
    xs = grid.coordinates(noisy_reversals(grid, 500, 7))
    for initial in ("negative", "positive"):
        moved, replayed = MemoryCurve(10, initial), MemoryCurve(10, initial)
        everett_terms(moved, xs)
        replayed.replay(xs)
        assert moved == replayed and moved.position == replayed.position


def test_a_design_adopts_only_an_operator_of_its_own_inputs():
    grid = Grid(5, 0.0, 1.0)
    v = noisy_reversals(grid, 50, 8)
    op = RegressorOperator(grid, v, False)
    design = Design(grid, v, thermal_term=False)
    assert design.adopt(op).operator is op
    with pytest.raises(ValueError, match="another design"):
        Design(grid, v + 0.01, thermal_term=False).adopt(op)
    with pytest.raises(ValueError, match="another design"):
        Design(grid, v, thermal_term=True).adopt(op)
    with pytest.raises(ValueError, match="another design"):
        Design(grid, v, thermal_term=False, initial="positive").adopt(op)


@pytest.mark.parametrize("levels", [1, 3, 6])
def test_the_vectorised_replay_emits_the_loops_terms_in_its_order(levels):
    """Ties (a fall to a corner's own b remakes it), saturation, repeated inputs, both initial states and a
    history: the same terms, in the same order, and the same curve at the end as one input at a time."""
    from identify.everett import _everett_terms_loop, _everett_terms_vectorised
    from identify.regressor import initial_curve

    rng = np.random.default_rng(levels)
    grid = Grid(levels, 0.0, float(levels))
    for trial in range(400):
        n = int(rng.integers(0, 40))
        kind = trial % 4
        if kind == 0:
            xs = rng.uniform(-1, levels + 1, n)
        elif kind == 1:
            xs = rng.integers(-1, levels + 2, n).astype(float)
        elif kind == 2:
            xs = np.round(rng.uniform(-0.5, levels + 0.5, n) * 2) / 2
        else:
            xs = np.cumsum(rng.normal(size=n)) + levels / 2
        initial = "negative" if trial % 3 else "positive"
        history = None if trial % 5 else rng.uniform(-1, levels + 1, int(rng.integers(0, 6)))
        loop, vectorised = initial_curve(grid, initial, history), initial_curve(grid, initial, history)
        expected = _everett_terms_loop(loop, xs)
        got = _everett_terms_vectorised(vectorised, xs)
        for e, g in zip(expected, got):
            np.testing.assert_array_equal(g, e)
        assert vectorised == loop and vectorised.position == loop.position


def test_a_rank_deficient_gram_matrix_is_factored_exactly():
    """Inputs that never reach the upper cells (a Gram matrix of rank below P, where Cholesky fails):
    the pivoted factor reproduces the Gram matrix and the right-hand side, and the factor's least-squares
    residual is the dense problem's."""
    grid = Grid(8, 0.0, 1.0)
    v = 0.45 * noisy_reversals(grid, 400, 11)  # the upper half of the Preisach plane is never switched
    op = RegressorOperator(grid, v, True)
    rows = np.arange(0, 400, 2)
    a = op.dense_rows(rows)
    rank = np.linalg.matrix_rank(a)
    assert rank < a.shape[1]
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.cholesky(a.T @ a)
    y = np.random.default_rng(11).normal(size=rows.size)
    r, z = nnls._gram_factor(op, rows, y)
    assert r.shape == (rank, a.shape[1])
    np.testing.assert_allclose(r.T @ r, a.T @ a, rtol=0, atol=1e-11 * np.abs(a.T @ a).max())
    np.testing.assert_allclose(r.T @ z, a.T @ y, rtol=0, atol=1e-10 * np.abs(a.T @ y).max())
    w = np.linalg.lstsq(r, z, rcond=None)[0]
    best = np.linalg.lstsq(a, y, rcond=None)[0]
    assert np.linalg.norm(a @ w - y) == pytest.approx(np.linalg.norm(a @ best - y), rel=1e-9)
