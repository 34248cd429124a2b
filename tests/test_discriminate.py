"""The discriminating run: the separation of rival models on a run (hand-computed small cases and what a
re-fit absorbs), the greedy design's limits, and ``rig diagnose --discriminate`` on recorded sessions."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from identify import Grid
from identify.diagnosis.discriminate import TARGET_SEPARATION, Rival, design, probe, separation
from identify.model import PreisachModel
from identify.regressor import regressor_matrix
from rig.acquisition.sequence import read_setpoint_file
from rig.diagnosis.loading import load_runs
from rig.diagnosis.simulate import SimulatedBench, simulate
from sessions import read_session

from .cli import assert_one_line_error, rig_here

GRID = Grid(4, 0.0, 4.0)
SIGMA = 0.1


def _base(seed: int = 3) -> PreisachModel:
    rng = np.random.default_rng(seed)
    return PreisachModel(GRID, rng.uniform(0.1, 1.0, GRID.n_cells), mu0=-2.0, c_d=0.3)


def _run():
    v = np.array([0.5, 1.5, 3.5, 2.5, 1.0, 3.0, 0.5, 3.9, 2.0, 1.2])
    return probe(v, np.full(v.size, 10.0), initial_V=0.0)


def _moved(model: PreisachModel, cell: int, by: float) -> PreisachModel:
    d = model.density.copy()
    d[cell] += by
    return replace(model, density=d)


def test_a_difference_of_bias_and_thermal_term_is_no_difference():
    base = _base()
    a = Rival("offset", (replace(base, mu0=base.mu0 + 0.7),))
    b = Rival("thermal", (replace(base, c_d=base.c_d - 0.2),))
    s, pairs = separation([a, b], base, _run(), SIGMA)
    assert s == pytest.approx(0.0, abs=1e-9) and set(pairs) == {"offset|thermal"}


def test_two_cells_are_separated_by_what_the_other_cannot_refit():
    base, run = _base(), _run()
    a, b = Rival("a", (_moved(base, 1, 0.5),)), Rival("b", (_moved(base, 7, -0.4),))
    s_reg = regressor_matrix(GRID, run.inputs, True)
    one, v = np.ones(run.n), run.inputs
    d = 0.5 * s_reg[:, 1] + 0.4 * s_reg[:, 7]  # f_a - f_b

    def unexplained(cols):  # || (I - P) d || by the normal equations, not the module's lstsq
        x = np.column_stack(cols)
        return np.linalg.norm(d - x @ np.linalg.solve(x.T @ x, x.T @ d))

    expected = min(unexplained([one, v, -0.4 * s_reg[:, 7]]), unexplained([one, v, 0.5 * s_reg[:, 1]])) / SIGMA
    s, _ = separation([a, b], base, run, SIGMA)
    assert expected > 1.0 and s == pytest.approx(expected, rel=1e-9)


def test_a_nuisance_that_spans_the_difference_absorbs_it():
    base, run = _base(), _run()
    diff = _moved(base, 1, 0.5).predict(run.inputs) - base.predict(run.inputs)
    drifting = Rival("drift", (_moved(base, 7, -0.4),), nuisance=lambda r: diff[:, None])
    s, _ = separation([Rival("a", (_moved(base, 1, 0.5),)), drifting], base, run, SIGMA)
    assert s == pytest.approx(0.0, abs=1e-9)


def test_a_run_that_never_leaves_its_initial_input_has_a_history():
    """A plan's first hold may stay at the saturation it starts from: nothing moves, no reversal."""
    run = probe(np.zeros(4), np.full(4, 30.0), initial_V=0.0)
    h = run.history
    assert h.branch.shape == (4,) and h.reversal_index.size == 0 and np.all(h.last_step_V == 0)


def test_the_design_keeps_the_limits_and_reports_its_own_separation():
    base = _base()
    rivals = [Rival("a", (_moved(base, 1, 0.05),)), Rival("b", (_moved(base, 7, -0.04),))]
    plan = design(rivals, base, 0.0, 4.0, SIGMA, points=50, rig_time_s=2000.0, seed=1)
    assert 0 < plan.points <= 50 and plan.rig_time_s <= 2000.0
    assert np.all((plan.v_V >= 0.0) & (plan.v_V <= 4.0)) and np.all(plan.dwell_s > 0)
    again, _ = separation(rivals, base, probe(plan.v_V, plan.dwell_s, initial_V=0.0), SIGMA)
    assert plan.separation == pytest.approx(again, rel=1e-6) and plan.separation > 0
    same = design(rivals, base, 0.0, 4.0, SIGMA, points=50, rig_time_s=2000.0, seed=1)
    assert np.array_equal(same.v_V, plan.v_V) and np.array_equal(same.dwell_s, plan.dwell_s)


def _reference_separation(rivals, base, run, sigma, memo=None):
    """The separation as first written: each pair re-builds both rivals' re-fit columns (a drift's nuisance
    once per pair it is in), each drift secant its own replay, and every prediction from the start (the
    design's ``memo`` is not used)."""
    from itertools import combinations

    from identify.diagnosis.discriminate import _nested, _refit_columns, _unexplained

    f0 = base.predict(run.inputs)
    preds = [[m.predict_run(run) for m in r.models] for r in rivals]
    pairs = {}
    for (i, a), (j, b) in combinations(enumerate(rivals), 2):
        worst = np.inf
        for fa in preds[i]:
            for fb in preds[j]:
                d = fa - fb
                s_ab = _unexplained(d, _refit_columns(b, f0, fb, run)) if not _nested(b, a) else np.inf
                s_ba = _unexplained(d, _refit_columns(a, f0, fa, run)) if not _nested(a, b) else np.inf
                worst = min(worst, s_ab, s_ba)
        pairs[f"{a.name}|{b.name}"] = float(worst / sigma)
    return min(pairs.values()), pairs


def _reference_secants(self, ctx, i, basis, form):
    """An ambient drift's secants as first written: one replay of the run per spline."""
    from identify.effects.ambient_drift import SECANT, moved_input

    run, x, before = ctx.runs[i], ctx.inputs[i], ctx.thermal[i]
    base = ctx.response(i, x)
    step = SECANT * (ctx.grid.step ** 2 if form == "shift" else ctx.grid.step / (ctx.grid.v_max - ctx.grid.v_min))
    out = np.empty(basis.shape)
    d = self.drift(run)
    for j in range(basis.shape[1]):
        out[:, j] = (ctx.response(i, moved_input(before, d + step * basis[:, j], form)) - base) / step
    return out


def test_the_design_with_a_drift_rival_is_the_reference_designs_to_the_bit(monkeypatch):
    """The design's shortcuts (each rival's re-fit columns built once per candidate plan, a drift's secants
    replayed in one batch) must design the same plan with the same separations as the plain computation."""
    import identify.diagnosis.discriminate as disc
    from identify.effects import Context
    from identify.effects.ambient_drift import AmbientDrift

    base = _base()
    knots = [0.0] * 3 + list(np.linspace(0.0, 3000.0, 6)) + [3000.0] * 3
    waves = np.arange(len(knots) - 4)

    def rival(name, coef, form):
        drift = AmbientDrift({"runs": {"plan": {"knots_s": knots, "coefficients": list(coef)}}, "form": form})

        def nuisance(run):
            return np.hstack(drift.nuisance_columns(Context.of_model(base, (run,)),
                                                    {"knot_s": 500.0, "smoothing": 1.0}).values)

        return Rival(name, (replace(base, effects=(drift,)),), nuisance)

    # two drifts (each re-fits its own nuisance against the other) and a cell the base model lacks
    rivals = [rival("shift", 0.05 * np.sin(waves), "shift"), rival("gain", 0.02 * np.cos(waves), "gain"),
              Rival("cell", (_moved(base, 7, -0.04),))]
    fast = design(rivals, base, 0.0, 4.0, SIGMA, points=40, rig_time_s=3000.0, seed=2)
    monkeypatch.setattr(disc, "separation", _reference_separation)
    monkeypatch.setattr(AmbientDrift, "_secants", _reference_secants)
    slow = design(rivals, base, 0.0, 4.0, SIGMA, points=40, rig_time_s=3000.0, seed=2)
    assert fast.points > 10 and min(fast.pairs.values()) > 0.1
    assert np.array_equal(fast.v_V, slow.v_V) and np.array_equal(fast.dwell_s, slow.dwell_s)
    assert fast.separation == slow.separation and fast.pairs == slow.pairs


# ----------------------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def creep_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("creep")
    return simulate(SimulatedBench("creep", 0.1, seed=1, levels=8, check_points=100), d)


def test_bad_limits_and_an_existing_plan_are_refused_before_any_work(creep_runs, tmp_path):
    fit, check = creep_runs
    plan = tmp_path / "plan.csv"
    for extra, words in ((["--points", "5"], "between 10 and 10000"), (["--points", "20000"], "between 10"),
                         (["--rig-time", "0"], "positive"), (["--rig-time", "-3"], "positive")):
        assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", check, "--discriminate", plan, *extra),
                              words)
        assert not plan.exists()
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", check, "--points", "50"), "--discriminate")
    plan.write_text("keep me\n")
    assert_one_line_error(rig_here("diagnose", "--fit", fit, "--check", check, "--discriminate", plan), "exists",
                          "--force")
    assert plan.read_text() == "keep me\n"


def test_a_plan_is_written_for_rivals_the_check_run_leaves_open(creep_runs, tmp_path):
    fit, check = creep_runs
    plan = tmp_path / "plan.csv"
    run = rig_here("diagnose", "--fit", fit, "--check", check, "--with", "baseline_drift,joule_power", "--json",
                   "--discriminate", plan, "--points", "60")
    assert run.code == 0, run.err
    out = run.json()
    assert out["verdict"]["status"] in ("unexplained", "ambiguous", "cannot_tell")
    disc = out["discriminate"]
    assert {"between", "plan", "points", "rig_time_s", "predicted_separation"} <= set(disc)
    assert len(disc["between"]) >= 2 and disc["plan"] == str(plan)
    v, dwell = read_setpoint_file(plan)
    recorded = load_runs([fit], [check]).check[0]
    assert v.size == disc["points"] <= 60 and dwell is not None and dwell.sum() == pytest.approx(disc["rig_time_s"])
    assert dwell.sum() <= np.sum(recorded.dwell_s) + 1e-9  # no more rig time than the check run
    grid = read_session(fit).grid
    assert np.all((v >= grid.v_min - 1e-9) & (v <= grid.v_max + 1e-9))
    assert disc["predicted_separation"]["plan"] >= TARGET_SEPARATION
    assert disc["predicted_separation"]["check"] is not None
    text = rig_here("diagnose", "--fit", fit, "--check", check, "--with", "baseline_drift,joule_power",
                    "--discriminate", plan, "--points", "60", "--force")
    assert text.code == 0 and f"discriminate: wrote {plan}" in text.out


def test_no_plan_when_the_verdict_is_clear_or_the_limits_cannot_separate(creep_runs, tmp_path):
    fit, check = creep_runs
    plan = tmp_path / "plan.csv"
    clear = rig_here("diagnose", "--fit", fit, "--check", check, "--with", "creep,baseline_drift", "--json",
                     "--discriminate", plan)
    assert clear.code == 0, clear.err
    out = clear.json()
    assert out["verdict"]["status"] == "explained" and out["discriminate"]["plan"] is None
    assert "clear" in out["discriminate"]["reason"] and not plan.exists()
    short = rig_here("diagnose", "--fit", fit, "--check", check, "--with", "baseline_drift,gain_drift", "--json",
                     "--discriminate", plan, "--points", "10")
    assert short.code == 0, short.err
    disc = short.json()["discriminate"]
    assert disc["plan"] is None and not plan.exists()
    assert disc["predicted_separation"]["plan"] < TARGET_SEPARATION and "short of" in disc["reason"]
