"""Blind generator F: strength 0 is the clean device, determinism, every mechanism acts,
realisations independent of the strength and of the other mechanisms, the logger."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_f
from benchmarks.blind.gen_f import engine, paths, schedules

ALL = gen_f.LIBRARY + gen_f.OUTSIDE


@pytest.fixture(scope="module")
def device():
    return base.draw_device(12)


@pytest.fixture(scope="module")
def full():
    return schedules.session(3)


@pytest.fixture(scope="module")
def short(full):
    return schedules.shortened(full, 90)


@pytest.fixture(scope="module")
def short_clean(device, short):
    return gen_f.simulate(device, short, [], 5, None)


@pytest.fixture(scope="module")
def swing(device):
    return engine.device_scales(device).swing


def _form(family, k=0):
    return gen_f.draw_form(family, np.random.default_rng(1000 + 17 * k + len(family)))


def _diff(a, b):
    return np.concatenate([x["y_um"] - y["y_um"] for x, y in zip(a, b)])


def test_names():
    assert set(gen_f.LIBRARY) == {
        "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
        "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift"}
    assert len(gen_f.LIBRARY) == 10
    assert {"backlash", "accommodation"} <= set(gen_f.OUTSIDE) and len(gen_f.OUTSIDE) == 3
    assert not set(gen_f.LIBRARY) & set(gen_f.OUTSIDE)


def test_forms_json_safe_deterministic_and_broad():
    for fam in ALL:
        rng1, rng2 = np.random.default_rng(4), np.random.default_rng(4)
        forms = [gen_f.draw_form(fam, rng1) for _ in range(40)]
        assert forms == [gen_f.draw_form(fam, rng2) for _ in range(40)]
        assert json.loads(json.dumps(forms)) == forms
        assert len({json.dumps(f, sort_keys=True) for f in forms}) > 20  # broad families
    kernels = {gen_f.draw_form("creep", np.random.default_rng(i))["kernel"] for i in range(60)}
    assert len(kernels) == 4
    lag = {gen_f.draw_form("thermal_lag", np.random.default_rng(i))["sign"] for i in range(60)}
    assert lag == {"lag", "overshoot", "mixed"}
    with pytest.raises(KeyError):
        gen_f.draw_form("nonsense", np.random.default_rng(0))


def test_schedules():
    ident = schedules.identification_run()
    assert ident["v_V"].size == 467 and np.all(ident["dwell_s"] == 20.0)
    walls = schedules.walls()
    assert np.all(np.isin(ident["v_V"], walls))
    check = schedules.check_run(1)
    v, d = check["v_V"], check["dwell_s"]
    assert v.size == 360 and v.min() >= 0 and v.max() <= 6
    assert d.min() >= 8 and d.max() <= 60
    steps = np.diff(v)
    assert np.any(steps == 0) and np.any(np.abs(steps[steps != 0]) < 0.01) and np.abs(steps).max() > 3
    assert np.count_nonzero(np.diff(np.sign(steps[steps != 0]))) > 50  # many reversals


def test_strength_zero_is_clean_device(device, full):
    zero = [(fam, _form(fam), 0.0) for fam in ALL]
    for effects in ([], zero):
        runs = gen_f.simulate(device, full, effects, 9, None)
        for run, sch in zip(runs, full):
            np.testing.assert_array_equal(run["y_um"], base.clean_outputs(device, sch["v_V"]))
            np.testing.assert_array_equal(run["v_V"], sch["v_V"])


def test_logger_writes_time_stamps_only(device, short):
    runs = gen_f.simulate(device, short, [], 3, None)
    for run, sch in zip(runs, short):
        assert set(run) == {"t_s", "v_V", "y_um"}
        t = run["t_s"]
        assert t.shape == sch["v_V"].shape
        gaps = np.diff(t) - sch["dwell_s"][1:]
        assert np.all(gaps > 0.04) and np.all(gaps < 0.6)
        assert sch["dwell_s"][0] + 0.3 < t[0] < sch["dwell_s"][0] + 2.0
        np.testing.assert_array_equal(t, np.round(t, 3))
    again = gen_f.simulate(device, short, [], 3, None)
    other = gen_f.simulate(device, short, [], 4, None)
    np.testing.assert_array_equal(runs[1]["t_s"], again[1]["t_s"])
    assert not np.array_equal(runs[1]["t_s"], other[1]["t_s"])


def test_determinism(device, short):
    effects = [("ambient_drift", _form("ambient_drift"), 1.0), ("first_point", _form("first_point"), 0.7)]
    a = gen_f.simulate(device, short, effects, 21, 0.05)
    b = gen_f.simulate(device, short, effects, 21, 0.05)
    c = gen_f.simulate(device, short, effects, 22, 0.05)
    for x, y in zip(a, b):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    assert not np.array_equal(a[1]["y_um"], c[1]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(device, short, short_clean, swing, family):
    for k in range(2):
        runs = gen_f.simulate(device, short, [(family, _form(family, k), 1.0)], 5, None)
        d = _diff(runs, short_clean)
        assert np.all(np.isfinite(d))
        assert np.max(np.abs(d)) > 1e-3 * swing, (family, k)
        assert np.max(np.abs(d)) < 0.2 * swing, (family, k)  # physical: a few percent


@pytest.mark.parametrize("family", ["thermal_lag", "creep", "reversible", "backlash", "gain_drift"])
def test_effect_grows_with_strength(device, short, short_clean, family):
    form = _form(family, 1)
    rms = [np.sqrt(np.mean(_diff(gen_f.simulate(device, short, [(family, form, s)], 5, None), short_clean) ** 2))
           for s in (0.1, 0.5, 1.0, 3.0)]
    assert np.all(np.diff(rms) > 0)


def test_additive_drifts_scale_with_strength(device, short, short_clean):
    for fam in ("baseline_drift", "gain_drift"):
        form = _form(fam, 2)
        d1 = _diff(gen_f.simulate(device, short, [(fam, form, 1.0)], 8, None), short_clean)
        d3 = _diff(gen_f.simulate(device, short, [(fam, form, 3.0)], 8, None), short_clean)
        np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-9)


def test_ambient_realisation_does_not_change_with_strength(device, short, short_clean):
    rng = np.random.default_rng(0)
    for _ in range(2):
        form = gen_f.draw_form("ambient_drift", rng)
        d_small = _diff(gen_f.simulate(device, short, [("ambient_drift", form, 0.3)], 8, None), short_clean)
        d_big = _diff(gen_f.simulate(device, short, [("ambient_drift", form, 0.6)], 8, None), short_clean)
        other = _diff(gen_f.simulate(device, short, [("ambient_drift", form, 0.6)], 9, None), short_clean)
        assert np.corrcoef(d_small, d_big)[0, 1] > 0.95
        assert np.corrcoef(d_big, other)[0, 1] < 0.95  # another seed: another path


def test_realisations_independent_of_other_mechanisms(device, short, short_clean):
    base_form, fp_form = _form("baseline_drift", 3), _form("first_point", 3)
    only_base = _diff(gen_f.simulate(device, short, [("baseline_drift", base_form, 1.0)], 8, None), short_clean)
    only_fp = _diff(gen_f.simulate(device, short, [("first_point", fp_form, 1.0)], 8, None), short_clean)
    both = _diff(gen_f.simulate(device, short, [("first_point", fp_form, 1.0),
                                                ("baseline_drift", base_form, 1.0)], 8, None), short_clean)
    np.testing.assert_allclose(both, only_base + only_fp, rtol=1e-9, atol=1e-9)


def test_noise_is_independent_of_the_effects(device, short, short_clean):
    noisy_clean = _diff(gen_f.simulate(device, short, [], 8, 0.1), short_clean)
    assert abs(np.std(noisy_clean) - 0.1) < 0.02
    effects = [("creep", _form("creep"), 1.0)]
    free = gen_f.simulate(device, short, effects, 8, None)
    noisy = gen_f.simulate(device, short, effects, 8, 0.1)
    np.testing.assert_allclose(_diff(noisy, free), noisy_clean, atol=1e-12)


def test_paths_are_normalised_and_seeded():
    grid = paths.session_grid(20000.0)
    runs = [(0.0, 9000.0), (9600.0, 20000.0)]
    for k in range(6):
        form = _form("baseline_drift", k)["path"]
        a = paths.session_path(form, engine.stream(1, "x"), grid, runs)
        b = paths.session_path(form, engine.stream(1, "x"), grid, runs)
        np.testing.assert_array_equal(a, b)
        assert a[0] == 0.0
        p2p = max(np.ptp(a[(grid >= s) & (grid <= e)]) for s, e in runs)
        assert abs(p2p - 1.0) < 1e-9


def test_pairs_compose(device, short, short_clean):
    effects = [("thermal_lag", _form("thermal_lag", 4), 1.0), ("interaction", _form("interaction", 4), 1.0)]
    d = _diff(gen_f.simulate(device, short, effects, 2, None), short_clean)
    assert np.all(np.isfinite(d)) and np.max(np.abs(d)) > 0


def test_a_full_session_simulates_both_runs(device, full):
    effects = [("interaction", _form("interaction", 5), 1.0), ("creep", _form("creep", 5), 1.0)]
    runs = gen_f.simulate(device, full, effects, 1, None)
    assert [r["y_um"].size for r in runs] == [467, 360]


def test_unknown_or_negative_rejected(device, short):
    with pytest.raises(KeyError):
        gen_f.simulate(device, short, [("nonsense", {}, 1.0)], 1, None)
    with pytest.raises(ValueError):
        gen_f.simulate(device, short, [("creep", _form("creep"), -1.0)], 1, None)
