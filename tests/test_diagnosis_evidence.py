"""A verdict bounded by its evidence: a measured floor for 'no gap', a bound otherwise, and the grid's
resolution as a candidate."""

import numpy as np
import pytest

from drivers.sim import SimParams, SimVO2
from identify import Grid, damped_oscillation
from identify.diagnosis import Run, check_design, diagnose
from identify.diagnosis.base import fit_base
from identify.diagnosis.noise import fit_residual_bound
from identify.diagnosis.resolution import Resolution, distinct_inputs, joint_refit_refused, refine_density
from identify.effects import make_effect
from identify.diagnosis.verdict import MAX_RIVALS, Evidence

SIGMA = 0.005


def _evidence(after, reference, floor, kind, estimate=None):
    m = reference.size
    names = tuple(f"e{i}" for i in range(len(after)))
    boot = np.tile(np.concatenate([[np.mean(reference**2)], [np.mean(a**2) for a in after]]), (50, 1))
    return Evidence(names, reference, np.array(after), None if floor is None else np.full(m, floor), 0.0, boot,
                    False, floor_kind=kind, floor_estimate=None if estimate is None else np.full(m, estimate))


def test_no_gap_needs_a_measured_floor_else_the_verdict_cannot_tell():
    rng = np.random.default_rng(1)
    m = 300
    noise = SIGMA * rng.normal(size=m)
    nothing = noise + 1e-4 * rng.normal(size=m)
    assert _evidence([nothing], noise, SIGMA, "measured").decide().status == "no_gap"
    # the same residual against a bound from the fit's residual only: it may be noise, it may not
    v = _evidence([nothing], noise, SIGMA, "bound").decide()
    assert v.status == "cannot_tell" and "repeat" in v.reason and v.effect is None
    # no estimate of the noise at all and no bin standing out: cannot tell either
    assert _evidence([nothing], noise, None, None).decide().status == "cannot_tell"
    # far above the bound it is a gap whatever the floor: an effect that explains it is named
    effect = 10 * SIGMA * np.sin(np.arange(m) / 9.0)
    v = _evidence([noise], noise + effect, SIGMA, "bound", estimate=SIGMA).decide()
    assert v.status == "explained" and v.effect == "e0"
    # ... and a gap no candidate explains is unexplained, not 'no gap'
    v = _evidence([noise + effect], noise + effect, SIGMA, "bound").decide()
    assert v.status == "unexplained"


def test_the_share_of_the_excess_never_exceeds_one_and_ambiguous_names_at_most_three_rivals():
    rng = np.random.default_rng(2)
    m = 400
    noise = SIGMA * rng.normal(size=m)
    effect = 6 * SIGMA * np.sin(np.arange(m) / 5.0)
    # a floor twice the true noise (it holds part of the effect): the candidate leaves less than the floor
    v = _evidence([noise], noise + effect, 2 * SIGMA, "measured").decide()
    assert v.status == "explained" and v.share_closed == 1.0 and v.steps[0]["share_closed"] <= 1.0
    # four candidates that explain it alike: ambiguous, the best first, no more than three rivals
    alike = [noise + 0.3 * SIGMA * rng.normal(size=m) for _ in range(4)]
    v = _evidence(alike, noise + effect, SIGMA, "measured").decide()
    assert v.status == "ambiguous" and len(v.rivals) == MAX_RIVALS == 3 and v.rivals[0] == v.contenders[0]
    best = int(np.argmin([np.mean(a**2) for a in alike]))
    assert v.rivals[0] == f"e{best}"


def _fit_with_residual(residual_scale):
    grid = Grid(6, 0.0, 3.0)
    truth = SimVO2(SimParams(levels=6, v_max_V=3.0)).true_model()
    v = damped_oscillation(grid, True)
    rng = np.random.default_rng(0)
    y = truth.predict(v) + residual_scale * rng.normal(size=v.size)
    run = Run("fit", v, y, np.cumsum(np.full(v.size, 20.0)), np.full(v.size, 20.0), 4)
    return fit_base(grid, (run,))


def test_the_bound_from_the_fit_residual_is_the_chi_square_upper_confidence_limit():
    from scipy import stats

    base = _fit_with_residual(0.01)
    b = fit_residual_bound(base)
    r = base.measured - base.fitted
    assert b.sigma_um == pytest.approx(np.sqrt(r @ r / stats.chi2.ppf(0.05, base.dof)))
    assert not b.measured and b.source == "fit_residual_bound"
    assert b.sigma_um > np.sqrt(r @ r / base.dof)  # an upper bound: above the point estimate


# ---------------------------------------------------------------- resolution
def _fine_device(levels=30):
    return SimVO2(SimParams(levels=levels)).true_model()


def test_a_refined_density_keeps_each_cells_weight_and_the_outputs_on_the_walls():
    coarse_grid = Grid(5, 0.0, 6.0)
    truth = _fine_device()
    base = fit_base(coarse_grid, (Run("fit", (v := damped_oscillation(coarse_grid, True)), truth.predict(v),
                                      np.arange(v.size, dtype=float), np.full(v.size, 20.0)),))
    fine = refine_density(base.model, 4)
    assert fine.grid.levels == 20 and np.all(fine.density >= 0)
    assert fine.density.sum() == pytest.approx(base.model.density.sum())
    walls = coarse_grid.walls
    seq = np.array([walls[5], walls[1], walls[4], walls[2], walls[3], walls[0], walls[5]])
    np.testing.assert_allclose(fine.predict(seq), base.model.predict(seq), atol=1e-10)
    # between the walls the two differ (that is the point of it)
    assert np.max(np.abs(fine.predict(seq + 0.3) - base.model.predict(seq + 0.3))) > 1e-3


def _runs_of(truth, fit_inputs, check, seed=0):
    rng = np.random.default_rng(seed)
    y_fit = truth.predict(fit_inputs) + SIGMA * rng.normal(size=fit_inputs.size)
    fit = Run("fit", fit_inputs, y_fit, np.cumsum(np.full(fit_inputs.size, 20.0)), np.full(fit_inputs.size, 20.0), 4)
    y = truth.predict(check.inputs) + SIGMA * rng.normal(size=check.inputs.size)
    return fit, Run("check", check.inputs, y, np.cumsum(check.dwell_s), check.dwell_s, 4)


@pytest.mark.slow
def test_a_coarse_grid_fitted_on_its_damped_oscillation_is_explained_by_resolution_never_no_gap():
    # the device is the simulator's L = 30 model; the fit uses L = 5: the gap is the grid
    grid = Grid(5, 0.0, 6.0)
    truth = _fine_device()
    for seed, points in ((4, 200), (5, 100)):
        check = check_design(0.0, 6.0, points, seed=seed)
        fit, chk = _runs_of(truth, damped_oscillation(grid, True), check)
        d = diagnose([fit], [chk], grid)
        assert d.verdict.status == "explained" and d.verdict.effect == "resolution", (seed, d.verdict)
        res = d.score("resolution")
        assert res.params["mode"] == "check_runs" and res.params["levels"] > 5 and res.shrink > 0.5
        # the identification run holds only the walls of L = 5: no finer model can be stored from it, and
        # the diagnosis says what would (an identification run on the finer grid)
        assert d.kept is not None and d.kept.error is not None and "rig acquire --levels" in d.kept.error
    # a shorter check run with the same gap: whatever is named, never 'no gap'
    fit, chk = _runs_of(truth, damped_oscillation(grid, True), check_design(0.0, 6.0, 15, seed=4))
    assert diagnose([fit], [chk], grid).verdict.status != "no_gap"


def test_a_run_of_many_distinct_inputs_refits_the_finer_grid_and_keeps_that_model():
    # identification on 400 random inputs: enough distinct inputs for L' = 18 refitted on them alone
    grid = Grid(9, 0.0, 6.0)
    truth = _fine_device()
    rng = np.random.default_rng(5)
    fit_inputs = np.round(rng.uniform(0.0, 6.0, 400), 4)
    check = check_design(0.0, 6.0, 160, seed=4)
    fit, chk = _runs_of(truth, fit_inputs, check, seed=1)
    res = Resolution(grid, (fit,), (chk,))
    assert distinct_inputs((fit,), grid) >= 390  # (rounded to 0.1 mV: a few coincide)
    assert {int(s["levels"]) for s in res.settings_grid() if s["mode"] == 0.0} >= {14, 18}
    d = diagnose([fit], [chk], grid)
    assert d.verdict.status == "explained" and d.verdict.effect == "resolution"
    score = d.score("resolution")
    assert score.params["mode"] == "refit"
    # the kept model is what `rig identify --levels N` stores: fitted on the identification run alone
    assert d.kept is not None and d.kept.error is None and d.kept.params["resolution"]["levels"] == score.params["levels"]
    assert d.kept.shrink > 0.5


@pytest.mark.parametrize("seed", [1, 3])
def test_a_finer_grid_and_a_reversible_term_are_both_named_from_their_joint_refit(seed):
    # the device: an L = 18 density (the ladder's 2x of L = 9) plus a decreasing reversible term, which no
    # non-negative density can mimic.  Paired with the L' = 18 model fitted without it, the reversible
    # columns recover little (the finer grid took part of the term into its density: old behaviour, one
    # name); the second step is the model rig identify --levels 18 --with reversible stores.
    truth = _fine_device(18)
    grid = Grid(9, 0.0, 6.0)
    rng = np.random.default_rng(5 + seed)
    fit_inputs = np.round(rng.uniform(0.0, 6.0, 400), 4)
    check = check_design(0.0, 6.0, 160, seed=4 + seed)

    def reading(v):
        return truth.predict(v) - 0.1 * np.tanh(2.0 * (v - 3.0)) + SIGMA * rng.normal(size=v.size)

    fit = Run("fit", fit_inputs, reading(fit_inputs), np.cumsum(np.full(400, 20.0)), np.full(400, 20.0), 4)
    chk = Run("check", check.inputs, reading(check.inputs), np.cumsum(check.dwell_s), check.dwell_s, 4)
    d = diagnose([fit], [chk], grid)
    assert d.verdict.status == "explained" and d.verdict.effects == ("resolution", "reversible"), d.verdict
    assert [s["effect"] for s in d.verdict.steps] == ["resolution", "reversible"]
    # what the second step scored is the model that is kept: both identified together on the fit run
    assert d.kept is not None and d.kept.error is None and d.kept.effects == ("resolution", "reversible")
    assert d.kept.params["resolution"]["levels"] == 18 and d.kept.shrink > d.score("resolution").shrink


def test_only_an_effect_fitted_in_one_solve_is_refitted_jointly_with_a_finer_grid():
    assert joint_refit_refused(make_effect("reversible")) is None
    for name in ("creep", "sensor_nonlinearity", "interaction", "thermal_lag"):  # searched or re-linearised
        assert "not one solve" in joint_refit_refused(make_effect(name)), name
    assert "per run" in joint_refit_refused(make_effect("baseline_drift"))


def test_resolution_is_not_assessed_when_no_finer_grid_can_be_identified_or_estimated():
    grid = Grid(30, 0.0, 6.0)
    truth = _fine_device()
    v = damped_oscillation(grid, True)
    fit = Run("fit", v, truth.predict(v), np.arange(v.size, dtype=float), np.full(v.size, 20.0))
    check = Run("check", v[:40], truth.predict(v[:40]), np.arange(40.0), np.full(40, 20.0))
    res = Resolution(grid, (fit,), (check,))
    # 32 distinct inputs in all: no finer grid can be identified; the interpolation is the fallback
    assert {s["mode"] for s in res.settings_grid()} == {2.0}
