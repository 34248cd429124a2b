"""The fast path of every method against the dense reference (cvxpy + Clarabel, scipy NNLS)."""

import numpy as np
import pytest
import scipy.sparse

from identify import METHODS, IdentifyError, Problem, damped_oscillation, make_method, random_input
from identify.dct import dct_matrix
from identify.fit import measurement_rows
from identify.methods import DAMPED_METHODS
from identify.methods import basis_pursuit as bp
from identify.methods.l1 import basis_pursuit
from rig.commands.demo import demo_truth as vo2_actuator


def noisy_problem(levels, fraction, seed, noise=0.05):
    truth = vo2_actuator(levels)
    v = damped_oscillation(truth.grid, thermal_term=True)
    clean = truth.predict(v)
    rng = np.random.default_rng(seed)
    y = clean + rng.uniform(-noise / 2, noise / 2, v.size)
    rows = measurement_rows(truth.grid, v, int(round(fraction * v.size)), seed, True)
    return Problem.build(truth.grid, v, y, rows), clean


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def forms_dense_regressor(method, solver):
    """Whether a fit with ``solver`` forms the dense ``S`` (``Problem.regressor``, built on first use).

    The dense reference formulation does; no fast path does (it never forms ``S``).  Every method
    accepts ``solver="dense"``, so accepting it proves nothing: a method whose dense setting quietly
    ran the fast path would be compared with itself.
    """
    problem, _ = noisy_problem(4, 0.65, 0)
    make_method(method, solver=solver).fit(problem)
    return "regressor" in vars(problem)


#: The methods with a dense reference formulation (solver="dense") that run on the damped oscillation.
SWITCHABLE = [m for m in DAMPED_METHODS if forms_dense_regressor(m, "dense")]


def test_the_paper_s_methods_and_smooth_nn_have_a_real_dense_reference_and_fast_paths_never_form_s():
    assert SWITCHABLE == ["ls", "cs", "cs_order", "cs_order_nn", "cs_nodct", "smooth_nn"]
    assert not any(forms_dense_regressor(m, "fast") for m in DAMPED_METHODS)


@pytest.mark.parametrize("method", SWITCHABLE)
@pytest.mark.parametrize("levels,fraction,seed", [(8, 0.65, 0), (12, 0.5, 1)])
def test_fast_agrees_with_dense_within_one_percent_of_the_modelling_error(method, levels, fraction, seed):
    problem, clean = noisy_problem(levels, fraction, seed)
    fast = make_method(method).fit(problem)
    dense = make_method(method, solver="dense").fit(problem)
    out_fast, out_dense = problem.fitted(fast.parameters_), problem.fitted(dense.parameters_)
    modelling = rms(out_dense - clean)
    assert rms(out_fast - out_dense) <= 0.01 * modelling
    if method in ("ls", "cs_order_nn"):
        assert np.all(fast.model_.density >= 0)


def test_splitting_alone_is_within_one_percent(monkeypatch):
    """Without the exact simplex finish (as for M > 1000) the certified gap is enough."""
    monkeypatch.setattr(bp, "POLISH_MAX_ROWS", 0)
    problem, clean = noisy_problem(14, 0.6, 3)
    for method in ("cs", "cs_order"):
        fast = make_method(method).fit(problem)
        assert fast.info_["pivots"] is None and fast.info_["status"] == "converged"
        dense = make_method(method, solver="dense").fit(problem)
        out_dense = problem.fitted(dense.parameters_)
        assert rms(problem.fitted(fast.parameters_) - out_dense) <= 0.01 * rms(out_dense - clean)


@pytest.mark.parametrize("seed", range(4))
def test_basis_pursuit_reaches_the_lp_optimum(seed):
    rng = np.random.default_rng(seed)
    n, m = 60, 35
    positions = np.sort(rng.choice(n, m, replace=False))
    q_true = np.zeros(n)
    q_true[rng.choice(n, 8, replace=False)] = rng.normal(size=8)
    psi_inv = dct_matrix(n).T
    y = psi_inv[positions] @ q_true + 0.01 * rng.normal(size=m)
    q, info = bp.basis_pursuit_dct(n, positions, y)
    q_ref, _ = basis_pursuit(psi_inv[positions], y)
    np.testing.assert_allclose(psi_inv[positions] @ q, y, atol=1e-12)
    assert info["relative_gap"] == 0.0  # certified by the simplex finish
    assert np.abs(q).sum() <= np.abs(q_ref).sum() * (1 + 1e-9)
    np.testing.assert_allclose(q, q_ref, atol=1e-6 * np.abs(q_ref).max())


@pytest.mark.parametrize("n,m", [(17, 12), (10, 7), (28, 9)])
def test_basis_pursuit_on_small_degenerate_problems(n, m):
    """Tiny DCTs have singular M x M submatrices: the finish must not trust one."""
    psi_inv = dct_matrix(n).T
    for seed in range(8):
        rng = np.random.default_rng(seed)
        positions = np.sort(rng.choice(n, m, replace=False))
        y = np.sort(rng.normal(size=m)) * 10  # sorted outputs, as 'CS Order' sees them
        q, _ = bp.basis_pursuit_dct(n, positions, y)
        q_ref, _ = basis_pursuit(psi_inv[positions], y)
        np.testing.assert_allclose(psi_inv[positions] @ q, y, atol=1e-9)
        assert np.abs(q).sum() == pytest.approx(np.abs(q_ref).sum(), rel=1e-7)


def test_noise_aware_basis_pursuit_keeps_its_bound_and_matches_the_reference():
    rng = np.random.default_rng(5)
    n, m = 80, 50
    positions = np.sort(rng.choice(n, m, replace=False))
    psi_inv = dct_matrix(n).T
    y = rng.normal(size=m)
    q, info = bp.basis_pursuit_dct(n, positions, y, epsilon=0.5, gap_tol=1e-7)
    q_ref, _ = basis_pursuit(psi_inv[positions], y, epsilon=0.5)
    assert np.linalg.norm(psi_inv[positions] @ q - y) <= 0.5 * (1 + 1e-9)
    assert np.abs(q).sum() == pytest.approx(np.abs(q_ref).sum(), rel=1e-5)


@pytest.mark.parametrize("n_points", [60, 400])
def test_least_squares_fast_path_is_lawson_hanson(n_points):
    """M < P: the operator's rows; M > P: the Gram factor. Both follow Lawson-Hanson exactly."""
    truth = vo2_actuator(8)
    v = random_input(truth.grid, n_points, seed=7)
    y = truth.predict(v) + np.random.default_rng(7).uniform(-0.05, 0.05, v.size)
    problem = Problem.build(truth.grid, v, y)
    fast = make_method("ls").fit(problem)
    dense = make_method("ls", solver="dense").fit(problem)
    assert fast.info_["reduced"] == (n_points > problem.n_parameters)
    np.testing.assert_allclose(fast.parameters_, dense.parameters_, atol=1e-6 * np.abs(dense.parameters_).max())


def test_nnls_interior_point_fallback_is_finished_exactly(monkeypatch):
    """If the active-set iteration does not settle, the interior point runs and is finished exactly."""
    from identify.methods import output_space

    problem, _ = noisy_problem(10, 0.6, 4)
    b_hat, _ = make_method("cs_order").reconstruct_sorted(problem)
    direct, info = output_space.nnls_outputs(problem.sparse_inverse, problem.n_cells, b_hat)
    assert info["status"] == "active set" and info["exact"]
    real = output_space._active_set_projection
    calls = []

    def first_fails(*args, **kwargs):
        calls.append(1)
        return None if len(calls) == 1 else real(*args, **kwargs)

    monkeypatch.setattr(output_space, "_active_set_projection", first_fails)
    fallback, info = output_space.nnls_outputs(problem.sparse_inverse, problem.n_cells, b_hat)
    assert info["status"] == "solved" and info["iterations"] > 0 and info["exact"]
    np.testing.assert_allclose(fallback, direct, atol=1e-9 * np.abs(direct).max())


def test_noise_aware_cs_nodct_keeps_its_bound_and_matches_the_reference_objective():
    problem, _ = noisy_problem(7, 0.6, 5)
    fast = make_method("cs_nodct", epsilon=0.05).fit(problem)
    dense = make_method("cs_nodct", epsilon=0.05, solver="dense").fit(problem)
    residual = problem.fitted(fast.parameters_)[problem.rows] - problem.measured
    assert np.linalg.norm(residual) <= 0.05 * (1 + 1e-6)
    cells = problem.n_cells
    assert np.abs(fast.parameters_[:cells]).sum() == pytest.approx(
        np.abs(dense.parameters_[:cells]).sum(), rel=1e-6
    )


def test_least_squares_beyond_the_dense_budget_runs_on_the_operator(monkeypatch):
    """Above DENSE_LH_ENTRIES no block of S is built; the answer is still a minimiser."""
    from identify.methods import nnls
    from identify.operators import RegressorOperator

    monkeypatch.setattr(nnls, "DENSE_LH_ENTRIES", 0)
    monkeypatch.setattr(nnls, "GRAM_LH_ENTRIES", 0)
    monkeypatch.setattr(RegressorOperator, "dense_rows", None)
    problem, _ = noisy_problem(6, 0.5, 0)
    fit = make_method("ls").fit(problem)
    assert fit.info_["path"] == "operator"
    ref = make_method("ls", solver="dense").fit(problem)
    assert fit.info_["residual_norm"] == pytest.approx(ref.info_["residual_norm"], rel=1e-9)


@pytest.mark.parametrize("method", list(METHODS))
def test_unknown_solver_is_refused(method):
    with pytest.raises(IdentifyError, match="solver"):
        make_method(method, solver="magic")


def test_every_method_has_a_dense_reference():
    assert {"ls", "cs", "cs_order", "cs_order_nn", "cs_nodct", "smooth_nn"} <= set(SWITCHABLE)


def test_nothing_dense_is_built_on_the_fast_path():
    problem, _ = noisy_problem(10, 0.6, 2)
    for method in DAMPED_METHODS:
        make_method(method).fit(problem)
    assert "regressor" not in vars(problem) and "square_lu" not in vars(problem)


def test_gram_blocks_by_mask_are_the_principal_submatrices():
    """The masked blocks of the projection are exactly ``G[idx][:, idx]``, empty rows included."""
    from identify.methods import output_space

    problem, _ = noisy_problem(10, 0.6, 4)
    cells = problem.sparse_inverse[: problem.n_cells]
    gram = scipy.sparse.csr_array(cells @ cells.T)
    blocks = output_space._SymmetricBlocks(gram)
    rng = np.random.default_rng(3)
    for fraction in (0.1, 0.5, 1.0):
        active = rng.random(problem.n_cells) < fraction
        idx = np.flatnonzero(active)
        np.testing.assert_array_equal(blocks.block(active).toarray(), gram[idx][:, idx].toarray())
