"""smooth_nn: the roughness penalty, GCV, the non-negative QP, and the method on any input."""

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

from identify import (
    Grid, IdentifyError, MethodNotApplicable, PreisachModel, Problem, choose_rows,
    damped_oscillation, make_method, random_input,
)
from identify.fit import fit_sequence
from identify.methods import nonneg_qp as qp_module
from identify.methods.gcv import gcv_curve, gcv_weight
from identify.methods.nonneg_qp import nonneg_qp
from identify.methods.normal_equations import normal_equations
from identify.methods.triangle_penalty import (
    difference_matrix, roughness, roughness_matrix, standard_form,
)
from identify.profiles import gaussian

from .cli import rig_here
from .conftest import known_model, write_csv


# ---------------------------------------------------------------- the penalty
def test_difference_matrix_of_two_levels_by_hand():
    grid = Grid(2, 0.0, 1.0)
    # parameter order: (1, 0), (1, 1), (0, 0)  (paper rows from the top)
    assert [(grid.cell_alpha[k], grid.cell_beta[k]) for k in range(3)] == [(1, 0), (1, 1), (0, 0)]
    d = difference_matrix(grid).toarray()
    edges = {tuple(row) for row in d}
    # (0,0)-(1,0) share the wall alpha = v_1; (1,0)-(1,1) share beta = v_1
    assert edges == {(-1.0, 0.0, 1.0), (1.0, -1.0, 0.0)}
    np.testing.assert_array_equal(
        roughness_matrix(grid).toarray(), [[2, -1, -1], [-1, 1, 0], [-1, 0, 1]]
    )
    assert roughness(grid, [1.0, 4.0, 0.0]) == 9.0 + 1.0


@pytest.mark.parametrize("levels", [1, 3, 7, 20])
def test_roughness_vanishes_exactly_on_constants(levels):
    grid = Grid(levels, 0.0, 1.0)
    d = difference_matrix(grid)
    assert d.shape == (levels * (levels - 1), grid.n_cells)
    assert np.all(np.abs(d).sum(axis=1) == 2) and np.all(d.sum(axis=1) == 0)
    values = np.linalg.eigvalsh(roughness_matrix(grid).toarray())
    assert np.sum(values < 1e-9) == 1  # the triangle is connected
    assert roughness(grid, np.full(grid.n_cells, 3.7)) == 0.0


def test_standard_form_whitens_the_penalty():
    grid = Grid(6, 0.0, 1.0)
    w = standard_form(grid)
    r = roughness_matrix(grid).toarray()
    np.testing.assert_allclose(w.T @ r @ w, np.eye(grid.n_cells - 1), atol=1e-10)
    np.testing.assert_allclose(w.T @ np.ones(grid.n_cells), 0.0, atol=1e-10)


# ---------------------------------------------------------------- GCV
def _problem(levels=5, n=40, m=None, thermal=True, noise=0.3, seed=0):
    truth = known_model(levels, seed=seed, c_d=0.75 if thermal else 0.0)
    v = random_input(truth.grid, n, seed=seed + 1)
    y = truth.predict(v) + np.random.default_rng(seed).uniform(-noise, noise, n)
    rows = None if m is None else choose_rows(n, m, seed)
    return truth, Problem.build(truth.grid, v, y, rows=rows, thermal_term=thermal)


def _brute_force_gcv(problem, lam):
    """GCV from the explicit hat matrix of the unconstrained penalised problem."""
    ne = normal_equations(problem)
    x = problem.measured_regressor
    n, p = problem.n_cells, problem.n_parameters
    penalty = np.zeros((p, p))
    penalty[:n, :n] = roughness_matrix(problem.grid).toarray()
    hat = x @ np.linalg.solve(x.T @ x + lam * penalty, x.T)
    m = x.shape[0]
    resid = ne.y - hat @ ne.y
    return m * (resid @ resid) / (m - np.trace(hat)) ** 2, np.trace(hat)


@pytest.mark.parametrize("m,keep_rows", [(12, True), (35, True), (35, False)])
def test_gcv_curve_matches_the_explicit_hat_matrix(m, keep_rows):
    # m = 12 < cells (data space), 35 > cells (parameter space), and without the rows kept
    _, problem = _problem(levels=5, n=40, m=m)
    ne = normal_equations(problem, keep_rows=keep_rows)
    lams = np.array([1e-3, 0.05, 1.0, 30.0])
    curve = gcv_curve(ne, problem.grid, n_free=2, lams=lams)
    assert curve.space == ("data" if m < 15 and keep_rows else "parameter")
    for lam, score, edf in zip(lams, curve.score, curve.edf):
        want_score, want_edf = _brute_force_gcv(problem, lam)
        assert edf == pytest.approx(want_edf, rel=1e-7)
        if m - want_edf <= 0.5:  # (almost) interpolating: GCV undefined, never chosen
            assert score == np.inf
        else:
            assert score == pytest.approx(want_score, rel=1e-6)
    assert np.isfinite(curve.score).sum() >= 2


def test_gcv_chooses_the_same_weight_in_data_and_parameter_space():
    _, problem = _problem(levels=6, n=60, m=18)
    a = gcv_weight(normal_equations(problem, keep_rows=True), problem.grid, 2)
    b = gcv_weight(normal_equations(problem, keep_rows=False), problem.grid, 2)
    assert (a.space, b.space) == ("data", "parameter")
    assert a.weight == pytest.approx(b.weight, rel=1e-6)
    assert a.score == pytest.approx(b.score, rel=1e-6)


def test_normal_equations_from_operator_blocks_equal_the_dense_products(monkeypatch):
    from identify.methods import normal_equations as ne_module

    _, problem = _problem(levels=5, n=40, m=25)
    monkeypatch.setattr(ne_module, "BLOCK_ENTRIES", 40 * 3)  # force 3-column blocks
    x = problem.measured_regressor
    for keep in (True, False):
        ne = ne_module.normal_equations(problem, keep_rows=keep)
        np.testing.assert_allclose(ne.hessian, x.T @ x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ne.gradient * ne.scale, x.T @ problem.measured, rtol=1e-12)
        assert (ne.rows_matrix is not None) == keep


# ---------------------------------------------------------------- the QP
def _check_kkt(q, c, x):
    grad = q @ x - c
    scale = np.abs(c).max()
    assert np.all(x >= 0)
    assert np.all(grad >= -1e-8 * scale)
    assert np.all(np.abs(grad[x > 0]) <= 1e-8 * scale)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 40))
def test_nonneg_qp_reaches_the_kkt_point(seed, n):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n + 3, n))
    q = a.T @ a + 1e-3 * np.eye(n)
    c = rng.standard_normal(n) * 5
    sol = nonneg_qp(q, c)
    x = sol.x
    _check_kkt(q, c, x)
    upper = scipy.linalg.cholesky(q)
    ref, _ = scipy.optimize.nnls(upper, scipy.linalg.solve_triangular(upper, c, trans="T"))
    np.testing.assert_allclose(x, ref, atol=1e-8 * max(1, np.abs(ref).max()))
    assert sol.active == int(np.sum(x == 0)) == sol.info()["active"]
    # the returned factor solves q on the free cells
    free = np.flatnonzero(sol.free)
    if free.size:
        np.testing.assert_allclose(sol.factor.solve(c[free]), x[free], rtol=1e-8, atol=1e-10)


def test_nonneg_qp_falls_back_to_lawson_hanson(monkeypatch):
    monkeypatch.setattr(qp_module, "MAX_STEPS", 1)
    rng = np.random.default_rng(3)
    a = rng.standard_normal((30, 20))
    q, c = a.T @ a, rng.standard_normal(20)
    sol = qp_module.nonneg_qp(q, c)
    assert sol.fallback and sol.active > 0
    _check_kkt(q, c, sol.x)


# ---------------------------------------------------------------- the method
def test_recovers_a_model_exactly_from_noise_free_rows_on_any_input():
    truth = known_model(6, mu0=-4.0, c_d=-2.0)
    v = random_input(truth.grid, 120, seed=1)  # off the walls, not a damped oscillation
    rep = fit_sequence(truth.grid, v, truth.predict(v), "smooth_nn")
    assert rep.info["selection"] == "gcv"
    w, want = rep.model.parameters(True), truth.parameters(True)
    assert np.linalg.norm(w - want) / np.linalg.norm(want) < 1e-5
    assert rep.model.mu0 == pytest.approx(-4.0, rel=1e-5)
    assert rep.model.c_d == pytest.approx(-2.0, rel=1e-5)


def test_uniform_density_is_found_from_few_noisy_rows():
    # a constant density has zero roughness: GCV pushes the weight up and the
    # fit is left with the constant and the bias, two numbers from 40 rows
    grid = Grid(10, 0.0, 1.0)
    truth = PreisachModel(grid, np.full(grid.n_cells, 5.0), mu0=1.0)
    v = damped_oscillation(grid)
    y = truth.predict(v) + np.random.default_rng(0).uniform(-0.5, 0.5, v.size)
    problem = Problem.build(grid, v, y, rows=choose_rows(v.size, 40, 0), thermal_term=False)
    fit = make_method("smooth_nn").fit(problem)
    assert np.sqrt(np.mean((fit.model_.density - 5.0) ** 2)) < 0.02
    ls = make_method("ls").fit(problem)
    assert np.sqrt(np.mean((ls.model_.density - 5.0) ** 2)) > 1.0  # what NNLS alone does


def test_beats_least_squares_on_a_smooth_density_from_few_rows():
    grid = Grid(16, 0.0, 1.0)
    truth = PreisachModel(grid, gaussian(grid))
    v = damped_oscillation(grid)
    y_true = truth.predict(v)
    rng = np.random.default_rng(1)
    problem = Problem.build(grid, v, y_true + rng.uniform(-2, 2, v.size),
                            rows=choose_rows(v.size, 80, 1), thermal_term=False)
    errors = {}
    for name in ("ls", "smooth_nn"):
        fit = make_method(name).fit(problem)
        errors[name] = np.sqrt(np.mean((problem.regressor @ fit.parameters_ - y_true) ** 2))
        assert np.all(fit.model_.density >= 0)
    assert errors["smooth_nn"] < 0.5 * errors["ls"]


@pytest.mark.slow
def test_iterative_solver_agrees_with_the_normal_equations():
    _, problem = _problem(levels=8, n=70, m=50, noise=0.2, seed=4)
    normal = make_method("smooth_nn", weight=0.05, algorithm="normal").fit(problem)
    iterative = make_method("smooth_nn", weight=0.05, algorithm="iterative").fit(problem)
    assert iterative.info_["converged"]
    s = problem.regressor
    diff = s @ (normal.parameters_ - iterative.parameters_)
    assert np.sqrt(np.mean(diff**2)) < 1e-4 * np.ptp(s @ normal.parameters_)
    # and with the weight chosen on held-out rows it stays close to the GCV fit
    chosen = make_method("smooth_nn", algorithm="iterative").fit(problem)
    gcv = make_method("smooth_nn").fit(problem)
    assert chosen.info_["selection"] == "hold-out"
    y = problem.measured
    for fit in (chosen, gcv):
        assert np.sqrt(np.mean((problem.measured_regressor @ fit.parameters_ - y) ** 2)) < 0.3


def _square_problem(levels: int, m: int, seed: int, thermal_term: bool = True,
                    noise: float = 5.0) -> tuple[np.ndarray, Problem]:
    grid = Grid(levels, 0.0, 1.0)
    truth = PreisachModel(grid, gaussian(grid), mu0=0.3, c_d=0.5 if thermal_term else 0.0)
    v = damped_oscillation(grid, thermal_term)
    y_true = truth.predict(v)
    rng = np.random.default_rng(seed)
    rows = choose_rows(v.size, m, seed, include=(v.size - 1,) if thermal_term else ())
    return y_true, Problem.build(grid, v, y_true + rng.uniform(-noise, noise, v.size), rows=rows,
                                 thermal_term=thermal_term)


@pytest.mark.parametrize("thermal_term", [True, False])
def test_output_space_algorithm_agrees_with_the_normal_equations(thermal_term):
    y_true, problem = _square_problem(12, 50, 5, thermal_term)
    s = problem.regressor
    # a given weight: the same QP, two formulations
    normal = make_method("smooth_nn", weight=0.05, algorithm="normal").fit(problem)
    outputs = make_method("smooth_nn", weight=0.05, algorithm="outputs").fit(problem)
    assert outputs.info_["algorithm"] == "outputs" and np.all(outputs.model_.density >= 0)
    scale = np.ptp(s @ normal.parameters_)
    assert np.sqrt(np.mean((s @ (normal.parameters_ - outputs.parameters_)) ** 2)) < 1e-5 * scale
    # GCV through the Schur complement of the output-space penalty picks the same weight,
    # and the fits agree to far below 1 % of the modelling error
    normal = make_method("smooth_nn", algorithm="normal").fit(problem)
    outputs = make_method("smooth_nn", algorithm="outputs").fit(problem)
    assert outputs.info_["selection"] == "gcv"
    assert outputs.info_["weight"] == pytest.approx(normal.info_["weight"], rel=1e-6)
    assert outputs.info_["edf"] == pytest.approx(normal.info_["edf"], rel=1e-6)
    modelling = np.sqrt(np.mean((s @ normal.parameters_ - y_true) ** 2))
    assert np.sqrt(np.mean((s @ (normal.parameters_ - outputs.parameters_)) ** 2)) < 1e-3 * modelling


def test_output_space_hold_out_choice_on_many_rows(monkeypatch):
    from identify.methods import smooth_square

    y_true, problem = _square_problem(12, 60, 6)
    monkeypatch.setattr(smooth_square, "GCV_MAX_ROWS", 10)  # the large-M branch on a small problem
    fit = make_method("smooth_nn", algorithm="outputs").fit(problem)
    assert fit.info_["selection"] == "hold-out"
    errors = [err for _, err in fit.info_["path"]]
    assert fit.info_["weight"] == fit.info_["path"][int(np.argmin(errors))][0]
    ls = make_method("ls").fit(problem)
    rmse = {f: np.sqrt(np.mean((problem.regressor @ f.parameters_ - y_true) ** 2)) for f in (fit, ls)}
    assert rmse[fit] < rmse[ls]


def test_output_space_algorithm_needs_the_square_design():
    _, problem = _problem(levels=8, n=70, m=50, noise=0.2, seed=4)
    with pytest.raises(MethodNotApplicable, match="square"):
        make_method("smooth_nn", algorithm="outputs").fit(problem)


def test_refuses_a_thermal_term_the_rows_cannot_identify():
    truth = known_model(5)
    v = damped_oscillation(truth.grid, True)
    problem = Problem.build(truth.grid, v, truth.predict(v), rows=np.arange(v.size - 1))
    with pytest.raises(MethodNotApplicable, match="thermal term"):
        make_method("smooth_nn").fit(problem)


def test_a_single_measurement_gives_a_flat_density():
    grid = Grid(4, 0.0, 1.0)
    v = damped_oscillation(grid)
    y = np.full(v.size, np.nan)
    y[3] = 2.0
    fit = make_method("smooth_nn").fit(Problem.build(grid, v, y, thermal_term=False))
    assert np.all(fit.model_.density >= 0) and np.ptp(fit.model_.density) < 1e-9


@pytest.mark.parametrize("settings_", [{"weight": 0.0}, {"weight": -1.0}, {"weight": float("nan")},
                                        {"algorithm": "magic"}])
def test_bad_settings(settings_):
    with pytest.raises(IdentifyError, match="smooth_nn"):
        make_method("smooth_nn", **settings_)


def test_solver_means_fast_or_dense_and_names_the_algorithm_setting():
    with pytest.raises(IdentifyError, match="algorithm='iterative'"):
        make_method("smooth_nn", solver="iterative")
    assert make_method("smooth_nn", solver="dense").settings() == {
        "solver": "dense", "weight": None, "algorithm": "auto"}


def test_rig_identify_knows_smooth_nn(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    v = random_input(truth.grid, 80, seed=2)
    path = write_csv(tmp_path / "trace.csv", v, truth.predict(v))
    run = rig_here("identify", path, "-L", 6, "--v-min", 0, "--v-max", 3, "--method", "smooth_nn",
              "--measurements", 60, "--json")
    assert run.code == 0, run.err
    out = run.json()
    assert out["method"] == "smooth_nn" and out["n_measured"] == 60
    assert np.all(np.array(out["density"]) >= 0) and out["rmse_um"] < 1e-3


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), levels=st.integers(1, 7), thermal=st.booleans(),
       damped=st.booleans(), noise=st.sampled_from([0.0, 0.01, 1.0]), frac=st.floats(0.0, 1.0))
def test_any_small_problem_gives_a_bounded_non_negative_fit(seed, levels, thermal, damped, noise, frac):
    # very few rows, collinear free columns, all-zero outputs: rounding must not blow up
    rng = np.random.default_rng(seed)
    grid = Grid(levels, 0.0, 1.0)
    v = damped_oscillation(grid, thermal) if damped else random_input(grid, int(rng.integers(2, 40)), seed)
    truth = PreisachModel(grid, rng.uniform(0, 3, grid.n_cells) * (rng.random(grid.n_cells) < 0.5),
                          mu0=rng.normal(), c_d=rng.normal() if thermal else 0.0)
    y = truth.predict(v) + noise * rng.uniform(-1, 1, v.size)
    m = 1 + int(frac * (v.size - 1))
    problem = Problem.build(grid, v, y, rows=choose_rows(v.size, m, seed), thermal_term=thermal)
    try:
        fit = make_method("smooth_nn").fit(problem)
    except MethodNotApplicable:
        assert thermal  # only the unidentifiable thermal term is refused
        return
    scale = max(1.0, np.abs(y).max())
    assert np.all(fit.model_.density >= 0)
    assert np.abs(fit.parameters_).max() < 1e4 * scale
    assert np.sqrt(np.mean((problem.measured_regressor @ fit.parameters_ - problem.measured) ** 2)) < 2 * scale


# ---------------------------------------------------------------- GCV without eigenvectors
@pytest.mark.parametrize("m", [1, 2, 7, 40])
def test_ridge_residuals_from_the_tridiagonal_form_equal_the_eigendecomposition(m):
    from identify.methods.gcv import _ridge_along

    rng = np.random.default_rng(m)
    b = rng.normal(size=(m, max(m - 2, 1)))  # rank-deficient for m > 3, like the projected rows
    k = b @ b.T
    v = rng.normal(size=m)
    lams = np.logspace(-6, 3, 13)
    values, rss = _ridge_along(k, v)
    s, u = np.linalg.eigh(k)
    np.testing.assert_allclose(np.sort(values), s, atol=1e-10 * s.max())
    want = ((lams[:, None] / (np.clip(s, 0, None)[None, :] + lams[:, None])) ** 2 * (u.T @ v) ** 2).sum(axis=1)
    np.testing.assert_allclose(rss(lams), want, rtol=1e-6)
    # no data: nothing to fit, no residual
    assert np.all(_ridge_along(k, np.zeros(m))[1](lams) == 0.0)


def test_grounded_root_stands_in_for_the_standard_form_once_constants_are_projected_out():
    from identify.methods.triangle_penalty import grounded_root

    grid = Grid(6, 0.0, 1.0)
    f, w = grounded_root(grid), standard_form(grid)
    assert np.allclose(np.triu(f, 1), 0.0)  # lower triangular
    n = grid.n_cells
    centre = np.eye(n) - 1.0 / n  # removes the constant weight
    np.testing.assert_allclose(centre @ f @ f.T @ centre, w @ w.T, atol=1e-10)
