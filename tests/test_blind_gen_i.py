"""Tests of the blind generator gen_i (benchmarks/blind/gen_i): SPEC.md's rules."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_i import LIBRARY, OUTSIDE, draw_form, simulate

ALL = LIBRARY + OUTSIDE


def _schedules(n1=467, n2=360, seed=0, K=40):
    """An identification run (damped oscillation on the grid's walls, 20 s dwells) and a check run
    (random reversals, steps from millivolts to the whole range, 8-60 s dwells, some repeats)."""
    j = np.arange(n1)
    amp = 3.0 * (1.0 - j / n1)
    v1 = np.clip(np.round((3.0 + amp * np.where(j % 2 == 0, 1.0, -1.0)) / 0.2) * 0.2, 0.0, 6.0)
    rng = np.random.default_rng(seed)
    v, d = [3.0], 1.0
    for _ in range(n2 - 1):
        if rng.uniform() < 0.1:
            v.append(v[-1])
            continue
        if rng.uniform() < 0.5:
            d = -d
        step = float(np.exp(rng.uniform(np.log(0.001), np.log(6.0))))
        x = v[-1] + d * step
        if not 0.0 <= x <= 6.0:
            d = -d
            x = v[-1] + d * step
        v.append(float(np.clip(x, 0.0, 6.0)))
    return [{"v_V": v1, "dwell_s": np.full(n1, 20.0), "readings": K},
            {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, n2), "readings": K}]


@pytest.fixture(scope="module")
def device():
    return base.draw_device(11)


@pytest.fixture(scope="module")
def short():
    return _schedules(n1=110, n2=90)


def _clean(device, schedules):
    return [base.clean_outputs(device, s["v_V"]) for s in schedules]


def test_names_and_forms_json_safe():
    assert len(LIBRARY) == 10 and len(set(LIBRARY)) == 10
    assert {"backlash", "accommodation"} <= set(OUTSIDE) and len(OUTSIDE) == 3
    assert not set(LIBRARY) & set(OUTSIDE)
    for fam in ALL:
        for k in range(5):
            a = draw_form(fam, np.random.default_rng(k))
            b = draw_form(fam, np.random.default_rng(k))
            assert a == b
            assert json.loads(json.dumps(a)) == a
    with pytest.raises(ValueError):
        draw_form("no_such_effect", np.random.default_rng(0))


def test_strength_zero_is_clean(device, short):
    clean = _clean(device, short)
    effects = [(fam, draw_form(fam, np.random.default_rng(3)), 0.0) for fam in ALL]
    for eff in ([], effects, effects[:1]):
        out = simulate(device, short, eff, 5, None)
        assert len(out) == 2
        for o, c, s in zip(out, clean, short):
            assert np.array_equal(o["y_um"], c)
            assert np.array_equal(o["v_V"], s["v_V"])
            assert np.all(np.diff(o["t_s"]) > 0)
            assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 2.0)


def test_deterministic(device, short):
    effects = [(fam, draw_form(fam, np.random.default_rng(1)), 1.0)
               for fam in ("thermal_lag", "ambient_drift", "creep", "baseline_drift", "gain_drift")]
    a = simulate(device, short, effects, 9, 0.05)
    b = simulate(device, short, effects, 9, 0.05)
    c = simulate(device, short, effects, 10, 0.05)
    for x, y in zip(a, b):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[key], y[key])
    assert not np.array_equal(a[0]["y_um"], c[0]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output(device, short, family):
    clean = _clean(device, short)
    swing = float(np.ptp(clean[0]))
    for k in range(2):
        form = draw_form(family, np.random.default_rng(20 + k))
        out = simulate(device, short, [(family, form, 1.0)], 4, None)
        dev = np.concatenate([o["y_um"] - c for o, c in zip(out, clean)])
        assert np.all(np.isfinite(dev))
        assert np.max(np.abs(dev)) > 1e-3 * swing, (family, form)
        assert np.max(np.abs(dev)) < 0.1 * swing, (family, form)   # physical at strength 1
        if k:
            continue
        # continuous at small strengths, growing with the strength
        small = simulate(device, short, [(family, form, 1e-6)], 4, None)
        dev_small = np.concatenate([o["y_um"] - c for o, c in zip(small, clean)])
        assert np.max(np.abs(dev_small)) < 1e-3 * np.max(np.abs(dev)) + 1e-9
        big = simulate(device, short, [(family, form, 3.0)], 4, None)
        dev_big = np.concatenate([o["y_um"] - c for o, c in zip(big, clean)])
        assert np.sqrt(np.mean(dev_big**2)) > np.sqrt(np.mean(dev**2))


def test_realisation_independent_of_strength_and_of_others(device, short):
    clean = _clean(device, short)
    for k in range(3):
        form = draw_form("baseline_drift", np.random.default_rng(k))
        one = simulate(device, short, [("baseline_drift", form, 1.0)], 2, None)
        two = simulate(device, short, [("baseline_drift", form, 2.5)], 2, None)
        for a, b, c in zip(one, two, clean):
            np.testing.assert_allclose(b["y_um"] - c, 2.5 * (a["y_um"] - c), atol=1e-9)
        # the drift's path does not change when another mechanism is present
        rev = ("reversible", draw_form("reversible", np.random.default_rng(k)), 1.0)
        both = simulate(device, short, [rev, ("baseline_drift", form, 1.0)], 2, None)
        only_rev = simulate(device, short, [rev], 2, None)
        for a, b, o in zip(one, both, only_rev):
            np.testing.assert_allclose(b["y_um"] - o["y_um"], a["y_um"] - base.clean_outputs(device, a["v_V"]),
                                       atol=1e-9)
        # each run has its own path
        assert not np.allclose(one[0]["y_um"][:80] - clean[0][:80], one[1]["y_um"][:80] - clean[1][:80])
    # gain drift: log of the factor scales with the strength
    form = draw_form("gain_drift", np.random.default_rng(4))
    g1 = simulate(device, short, [("gain_drift", form, 1.0)], 2, None)
    g3 = simulate(device, short, [("gain_drift", form, 3.0)], 2, None)
    for a, b, c in zip(g1, g3, clean):
        ok = np.abs(c) > 1.0
        np.testing.assert_allclose(np.log(b["y_um"][ok] / c[ok]), 3.0 * np.log(a["y_um"][ok] / c[ok]), atol=1e-9)
    # the noise does not depend on the effects
    n0 = simulate(device, short, [], 6, 0.1)
    eff = [("creep", draw_form("creep", np.random.default_rng(1)), 1.0)]
    n1 = simulate(device, short, eff, 6, 0.1)
    q1 = simulate(device, short, eff, 6, None)
    for a, b, q, c in zip(n0, n1, q1, clean):
        np.testing.assert_allclose(a["y_um"] - c, b["y_um"] - q["y_um"], atol=1e-9)
        assert 0.05 < np.std(a["y_um"] - c) < 0.2


def test_prefix_stable(device):
    sch = _schedules(n1=110, n2=90)
    third = _schedules(n1=60, n2=50, seed=3)[1]
    effects = [(fam, draw_form(fam, np.random.default_rng(7)), 1.0)
               for fam in ("thermal_lag", "ambient_drift", "creep", "first_point", "baseline_drift",
                           "gain_drift", "accommodation", "backlash", "interference_fringes")]
    for eff in (effects, effects[:1], []):
        one = simulate(device, sch[:1], eff, 8, 0.02)
        two = simulate(device, sch, eff, 8, 0.02)
        three = simulate(device, sch + [third], eff, 8, 0.02)
        assert np.array_equal(one[0]["t_s"], two[0]["t_s"]) and np.array_equal(one[0]["y_um"], two[0]["y_um"])
        for r in range(2):
            assert np.array_equal(two[r]["t_s"], three[r]["t_s"])
            assert np.array_equal(two[r]["y_um"], three[r]["y_um"])


def test_interaction_loop_gain_below_one(device):
    from benchmarks.blind.gen_i._util import reference
    from benchmarks.blind.gen_i.mechanisms import Interaction

    ref = reference(device)
    for k in range(10):
        form = draw_form("interaction", np.random.default_rng(k))
        inter = Interaction(form, 1e6, ref)
        slope = {"linear": 1.0, "saturating": 1.0, "asymmetric": 1 + abs(form["a"]), "quadratic": 1 + abs(form["b"])}
        gain = abs(inter.gamma) * ref.slope_max_um_per_V / ref.phase_half_um * slope[form["law"]]
        assert gain < 0.5


def test_cell_map_matches_device(device):
    from benchmarks.blind.gen_i._util import cell_thresholds

    up, dn = cell_thresholds(device)
    h = device.hysteresis()
    h.move(5.0)
    ph = h.move(4.4)
    on = (up < 5.0) & (dn < 4.4)
    assert ph == pytest.approx(-np.sum(device.density_um) + 2 * np.sum(device.density_um[on]), abs=1e-9)


def test_a_full_session_simulates_both_runs(device):
    sch = _schedules()
    effects = [(fam, draw_form(fam, np.random.default_rng(2)), 1.0) for fam in ALL]
    out = simulate(device, sch, effects, 1, None)
    assert [o["y_um"].size for o in out] == [467, 360]
    assert all(np.all(np.isfinite(o["y_um"])) for o in out)
    lag = simulate(device, sch, [("thermal_lag", effects[0][1], 1.0)], 1, None)
    assert all(np.all(np.isfinite(o["y_um"])) for o in lag)
