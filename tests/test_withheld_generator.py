"""The withheld-forms generator of benchmarks/withheld: its physics, seeds, calibration and scoring."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks.withheld import generate as G
from benchmarks.withheld import physics as P
from benchmarks.withheld.jobs import read_verdict
from benchmarks.withheld.run import score
from benchmarks.withheld.runs import config, fit_plan, noise_free_outputs, record_run
from drivers.sim import SimParams
from identify import Grid, random_input
from sessions import read_session

README = Path(__file__).resolve().parents[1] / "benchmarks" / "withheld" / "README.md"


def params(seed: int = 1, **changes) -> SimParams:
    sim = {**G.draw_base(seed)["sim"], "psd_noise_V": 0.0, **changes}
    return SimParams(levels=G.LEVELS, **sim)


def drive(device: P.WithheldVO2, inputs, dwell_s: float = 20.0, psd: bool = False) -> np.ndarray:
    """Noise-free outputs (um) after each set-point and its dwell."""
    out = []
    for v in inputs:
        device.apply_voltage(float(v))
        device.clock.sleep(dwell_s)
        out.append(device.read_psd() * device.params.psd_um_per_V if psd else device.deflection_um())
    return np.array(out)


def effect(name: str, strength: float, form: dict, run: int = 0) -> P.Withheld:
    return P.make_effect(name, strength, form, run, np.random.default_rng(5))


# ---------------------------------------------------------------- the device
def test_clean_device_of_a_drawn_base_is_equation_22_also_through_the_path_sampler():
    p = params(3)
    v = random_input(Grid(p.levels, p.v_min_V, p.v_max_V), 60, seed=2)
    # a play of zero width routes every event through the path-sampling update and changes nothing
    dev = P.make_device(p, [effect("backlash", 0.0, {"asymmetry": 0.0, "elastic": 0.0})])
    np.testing.assert_allclose(drive(dev, v), dev.true_model().predict(v), rtol=0, atol=1e-9)


def test_play_operator_hand_case_and_bound_on_the_device():
    e = effect("backlash", 1.0, {"asymmetry": 0.0, "elastic": 0.0})
    assert [e.deflection(u, None) for u in (0.0, 3.0, 2.5, 1.0, 4.0)] == [0.0, 2.0, 2.0, 2.0, 3.0]
    p = params(2)
    v = random_input(Grid(p.levels, p.v_min_V, p.v_max_V), 40, seed=4)
    clean = drive(P.make_device(p, []), v)
    played = drive(P.make_device(p, [effect("backlash", 0.3, {"asymmetry": 0.5, "elastic": 0.0})]), v)
    gap = played - clean
    assert np.all(gap <= 0.3 * 1.5 + 1e-12) and np.all(gap >= -0.3 * 1.5 - 1e-12)
    assert np.max(np.abs(gap)) > 0.1


@pytest.mark.parametrize("domain", ["voltage", "temperature"])
def test_interaction_input_is_self_consistent_after_every_reading(domain):
    p = params(4)
    e = effect("interaction", 0.4, {"sign": -1.0 if domain == "voltage" else 1.0, "domain": domain})
    dev = P.make_device(p, [e])
    v = random_input(Grid(p.levels, p.v_min_V, p.v_max_V), 25, seed=1)
    for x in v:
        dev.apply_voltage(float(x))
        dev.clock.sleep(20.0)
        dev.deflection_um()
        f = e.sign * 0.4 * dev.phase_um() / dev.amplitude_um
        want = dev._v_eq + f if domain == "voltage" else p.equivalent_voltage(p.kelvin_per_V2 * dev._v_eq**2 + f)
        assert dev._x_in == pytest.approx(want, abs=1e-10)


def test_first_point_offsets_follow_the_reversals_hand_case():
    p = params(1)
    form = {"sign_rule": "along", "sign": 1.0, "size_law": "constant", "scale_V": 1.0,
            "asymmetry": 0.0, "persistence": 0.5}
    v = [1.0, 2.0, 3.0, 2.0, 2.0, 1.0, 2.0, 2.5]
    off = drive(P.make_device(p, [effect("first_point", 0.1, form)]), v) - drive(P.make_device(p, []), v)
    # 3 -> 2 reverses (down: -0.1), the repeat keeps it, the next step halves it, 1 -> 2 reverses (up: +0.1)
    np.testing.assert_allclose(off, [0, 0, 0, -0.1, -0.1, -0.05, 0.1, 0.05], atol=1e-12)


def test_single_mode_thermal_lag_follows_its_closed_form():
    p = params(1, time_constant_s=0.0)
    e = effect("thermal_lag", 0.5, {"modes": [{"tau_s": 10.0, "weight": 1.0}], "voltage_share": 1.0})
    dev = P.make_device(p, [e])
    dev.apply_voltage(3.0)
    dev.clock.sleep(5.0)
    assert dev.state().preisach_input_V == pytest.approx(0.5 * 3.0 + 0.5 * 3.0 * -math.expm1(-0.5), abs=1e-12)


def test_multi_mode_lag_turning_points_match_fine_time_steps():
    p = params(2)
    form = {"modes": [{"tau_s": 1.0, "weight": 0.5}, {"tau_s": 40.0, "weight": 0.5}], "voltage_share": 0.3}
    v = [3.5, 4.5, 3.0, 3.4, 2.0, 4.0, 3.8]
    exact = drive(P.make_device(p, [effect("thermal_lag", 0.6, form)]), v, dwell_s=8.0)
    fine_e = effect("thermal_lag", 0.6, form)
    fine_e.max_step_s = 0.005
    fine = P.make_device(p, [fine_e])
    fine._turning_effects = []  # uniform small steps instead
    np.testing.assert_allclose(exact, drive(fine, v, dwell_s=8.0), atol=2e-4)
    assert np.max(np.abs(exact - drive(P.make_device(p, []), v, dwell_s=8.0))) > 0.05


def test_creep_after_one_step_is_its_kernel_times_the_output_change():
    p = params(1)
    form = {"kernel": "exponential", "tau_s": 10.0, "sign": 1.0, "driver": "total",
            "amplitude_power": 1.0, "asymmetry": 0.0}
    clean = drive(P.make_device(p, []), [0.0, 4.0], dwell_s=10.0)
    crept = drive(P.make_device(p, [effect("creep", 0.1, form)]), [0.0, 4.0], dwell_s=10.0)
    assert crept[1] - clean[1] == pytest.approx(0.1 * (clean[1] - clean[0]) * -math.expm1(-1.0), abs=1e-12)


def test_creep_with_excursion_memory_relaxes_towards_the_excursion_from_where_it_is():
    p = params(1)
    form = {"kernel": "exponential", "tau_s": 10.0, "sign": -1.0, "driver": "total",
            "amplitude_power": 1.0, "asymmetry": 0.0, "memory": "excursion"}
    v = [0.0, 4.5, 5.0, 4.0]  # the output rises, rises (through the transition), falls
    u = drive(P.make_device(p, []), v, dwell_s=10.0)
    assert u[1] > u[0] and u[2] > u[1] and u[3] < u[2]
    crept = drive(P.make_device(p, [effect("creep", 0.1, form)]), v, dwell_s=10.0)
    k = -math.expm1(-1.0)
    c1 = (u[1] - u[0]) * k
    c2 = c1 + ((u[2] - u[0]) - c1) * k  # same direction: the excursion grows from the last reversal
    c3 = c2 + ((u[3] - u[2]) - c2) * k  # reversal: a new excursion starts at the previous output
    np.testing.assert_allclose(crept - u, -0.1 * np.array([0.0, c1, c2, c3]), atol=1e-12)


def test_interaction_bound_keeps_the_loop_gain_below_one_half():
    p = params(2)
    for domain in ("voltage", "temperature"):
        k = P.interaction_bound(p, {"domain": domain})
        assert k > 0 and P.interaction_bound(p, {"domain": domain}, loop_gain=1.0) == pytest.approx(2 * k)


def test_slow_curves_start_at_zero_and_differ_between_runs_not_between_calls():
    for k in range(20):
        shape = P.draw_slow_shape(G.stream(k, "test"))
        f1, f1b = P.SlowCurve(shape, np.random.default_rng(1)), P.SlowCurve(shape, np.random.default_rng(1))
        f2 = P.SlowCurve(shape, np.random.default_rng(2))
        t = np.linspace(0.0, P.SESSION_S, 50)
        a, b, c = (np.array([f(x) for x in t]) for f in (f1, f1b, f2))
        assert a[0] == 0.0 and np.array_equal(a, b) and not np.allclose(a, c)
        assert 0.02 < np.max(np.abs(a)) < 20.0


def test_sensor_maps_are_monotone_at_every_strength():
    psd = np.linspace(-5.0, 5.0, 2001)
    for k in range(40):
        form = P.draw_sensor(G.stream(k, "sensor-test"), params())
        for s in (1e-3, 0.3, 2.0):
            e = effect("sensor_nonlinearity", s, form)
            out = np.array([e.psd(x, None) for x in psd])
            assert np.all(np.diff(out) > 0), (form, s)


# ---------------------------------------------------------------- seeds and cases
def test_splits_are_disjoint_and_cases_do_not_depend_on_order_or_subset():
    assert not set(G.SPLITS["dev"]) & set(G.SPLITS["headline"])
    a = G.draw_form(7, "creep")
    G.draw_form(7, "thermal_lag")
    assert G.draw_form(7, "creep") == a != G.draw_form(8, "creep")
    cases = G.make_cases("dev", 2)
    assert len(cases) == 2 * (1 + len(P.FAMILIES) + G.PAIRS_PER_SEED)
    assert {c.kind for c in cases} == {"none", "library", "outside", "pair"}
    covered = {p for i in range(36 // G.PAIRS_PER_SEED) for p in G.pairs_for(i)}
    assert len(covered) == 36
    assert G.make_cases("dev", 1, selection=G.parse_selection("creep+thermal_lag"))[0].effects == \
        ("thermal_lag", "creep")
    with pytest.raises(ValueError, match="unknown 'creeep'"):
        G.parse_selection("creeep")


def test_headline_draws_digest_is_the_one_in_the_readme():
    m = re.search(r"headline draws digest: `([0-9a-f]{16})`", README.read_text(encoding="utf-8"))
    assert m, "the README records the headline split's draws digest"
    assert G.digest(G.draws("headline", 10)) == m.group(1)


# ---------------------------------------------------------------- runs and calibration
def test_noise_free_outputs_are_what_the_session_records(tmp_path):
    cfg = config(G.draw_base(1)["sim"], 4, seed=3, noise=False)
    plan = fit_plan(Grid(4, cfg.sim.v_min_V, cfg.sim.v_max_V))
    forms = {"creep": G.draw_form(1, "creep"), "baseline_drift": G.draw_form(1, "baseline_drift")}

    def device():
        return P.make_device(cfg.sim, [P.make_effect(n, 0.05, f, 0, G.stream(1, n)) for n, f in forms.items()])

    mem = noise_free_outputs(cfg, device(), plan)
    session = read_session(record_run(cfg, device(), plan, tmp_path / "fit.h5"))
    np.testing.assert_array_equal(np.asarray(session.outputs), mem)


def test_strength_solver_reaches_the_target_or_says_it_cannot():
    calls = []

    def gap(s):
        calls.append(s)
        return 0.3 * s**1.7

    s, g, n = G.solve_strength(gap, 1.0, 0.015, None)
    assert abs(g / 0.015 - 1) <= G.GAP_RTOL and n == len(calls) <= 6 and g == gap(s)
    _, g, _ = G.solve_strength(lambda s: s / (1 + s), 0.01, 0.5, 10.0)
    assert g == pytest.approx(0.5, rel=G.GAP_RTOL)
    with pytest.raises(G.Unreachable):
        G.solve_strength(lambda s: s / (1 + s), 0.01, 0.95, 10.0)


def test_calibrated_first_point_opens_the_target_gap_on_a_clean_base():
    bench = G.Bench(1)
    assert G.rms(bench.base_residual()) < 1e-6 * bench.sigma_um * 100
    cal = G.calibrate(bench, "first_point", 3.0)
    assert cal.status == "ok" and abs(cal.gap_um / (3.0 * bench.sigma_um) - 1) <= G.GAP_RTOL
    assert bench.gap_um({"first_point": (cal.form, cal.strength)}) == cal.gap_um


# ---------------------------------------------------------------- reading the verdict
def test_verdict_reading_and_scoring_hand_cases():
    old = read_verdict({"verdict": {"status": "explained", "effect": "creep", "shrink": 0.7}})
    assert old["effects"] == ["creep"]
    new = read_verdict({"verdict": {"status": "explained", "effect": "creep", "effects": ["creep", "thermal_lag"]}})

    def row(kind, effects, verdict):
        return {"status": "ok", "kind": kind, "case": {"effects": effects}, "verdict": verdict}

    assert score(row("library", ["creep"], old)) == {"ok": True, "wrong": False, "column": "right"}
    # a right name with a wrong second one is a wrong name, counted strictly
    assert score(row("library", ["creep"], new)) == {"ok": False, "wrong": True, "column": "wrong"}
    assert score(row("pair", ["thermal_lag", "creep"], new))["ok"]
    assert not score(row("pair", ["thermal_lag", "creep"], old))["ok"]
    amb = read_verdict({"verdict": {"status": "ambiguous", "effect": "creep"}})
    assert score(row("outside", ["backlash"], amb)) == {"ok": True, "wrong": False, "column": "right"}
    assert score(row("outside", ["backlash"], old)) == {"ok": False, "wrong": True, "column": "wrong"}
    # a special case of the true mechanism is the same mechanism; an ambiguity is honest only with the oracle
    jp = read_verdict({"verdict": {"status": "explained", "effect": "joule_power"}})
    assert score(row("library", ["reversible"], jp))["column"] == "right"
    two = read_verdict({"verdict": {"status": "ambiguous", "rivals": ["creep", "baseline_drift"]}})
    assert score(row("library", ["creep"], two))["column"] == "open"
    assert score({**row("library", ["creep"], two), "oracle_z": 0.5})["column"] == "honest"
    assert score({**row("library", ["creep"], two), "oracle_z": 4.0})["column"] == "open"
    assert score(row("none", [], read_verdict({"verdict": {"status": "no_gap", "effect": None}})))["ok"]


def test_the_fresh_headline_seeds_are_the_ones_in_the_readme_and_keep_their_place():
    text = README.read_text(encoding="utf-8")
    m = re.search(r"seeds 900011-900020\n  \(`--skip 10`\): `([0-9a-f]{16})`", text)
    assert m, "the README records the fresh headline seeds' draws digest"
    assert G.digest(G.draws("headline", 10, skip=10)) == m.group(1)
    third = re.search(r"Seeds 900031-900040 \(`--skip 30`, stop 23\): draws\n  `([0-9a-f]{16})`", text)
    assert third and G.digest(G.draws("headline", 10, skip=30)) == third.group(1)
    fourth = re.search(r"Seeds 900041-900050 \(`--skip 40`,\n  stop 25\): draws `([0-9a-f]{16})`", text)
    assert fourth and G.digest(G.draws("headline", 10, skip=40)) == fourth.group(1)
    # a skipped seed keeps its place in the split: the same seed and the same pairs as without skipping
    skipped = G.make_cases("headline", 1, selection=G.parse_selection("pairs"), skip=10)
    full = [c for c in G.make_cases("headline", 11, selection=G.parse_selection("pairs")) if c.seed == 900011]
    assert [c.effects for c in skipped] == [c.effects for c in full] and skipped[0].seed == 900011
    with pytest.raises(ValueError):
        G.split_seeds("headline", 1, skip=len(G.SPLITS["headline"]))


# ---------------------------------------------------------------- the oracle
def test_the_oracle_is_the_true_signal_scored_beside_the_library():
    """The oracle candidate of an added signal closes the whole gap; a library candidate of another form
    closes less; and an oracle whose signal does not fit the runs says so."""
    from benchmarks.withheld.oracle import oracle_effect
    from identify.diagnosis import DiagnosisSettings, diagnose, library
    from tests.test_diagnosis import GRID, synthetic

    def extra(v, t):  # neither a drift nor a map of the input
        return 0.04 * ((v - 3.0) / 3.0) ** 3 * np.sin(t / 900.0)

    fit, check = synthetic(GRID, extra, seed=2)
    oracle = oracle_effect("oracle_total", (np.zeros(fit.n), extra(check.inputs, check.t_s)))
    settings = DiagnosisSettings(keep=False)  # an oracle is no effect a stored model could keep
    res = diagnose([fit], [check], GRID, settings, candidates=library(["baseline_drift"]) + [oracle])
    by = {c.effect: c for c in res.candidates}
    assert res.verdict.effect == "oracle_total"
    assert by["oracle_total"].shrink > by["baseline_drift"].shrink
    assert by["oracle_total"].rmse_um == pytest.approx(res.noise_floor_um, rel=0.3)
    with pytest.raises(ValueError, match="runs' signals"):
        diagnose([fit], [check], GRID, settings, candidates=[oracle_effect("o", (check.outputs,))])
