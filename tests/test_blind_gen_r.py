"""Tests of the blind generator ``benchmarks.blind.gen_r`` (see its README)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_r import LIBRARY, OUTSIDE, draw_form, simulate

ALL = LIBRARY + OUTSIDE


def _schedules(seed: int = 0, n1: int = 60, n2: int = 45) -> list[dict]:
    """A shortened session: a damped oscillation on the walls, then a random-reversal check run."""
    k = np.arange(n1)
    v1 = np.round((3.0 + 3.0 * (1.0 - k / n1) * (-1.0) ** k) / 0.2) * 0.2
    rng = np.random.default_rng(seed)
    v2, v = [], 0.0
    for i in range(n2):
        if i and rng.random() < 0.1:
            v2.append(v)
            continue
        step = float(np.exp(rng.uniform(np.log(1e-3), np.log(6.0))))
        v = float(np.clip(v + rng.choice([-1.0, 1.0]) * step, 0.0, 6.0))
        v2.append(v)
    return [
        {"v_V": v1, "dwell_s": np.full(n1, 20.0), "readings": 10},
        {"v_V": np.array(v2), "dwell_s": rng.uniform(8.0, 60.0, n2), "readings": 10},
    ]


@pytest.fixture(scope="module")
def device():
    return base.draw_device(7)


@pytest.fixture(scope="module")
def scheds():
    return _schedules()


@pytest.fixture(scope="module")
def clean(device, scheds):
    return [base.clean_outputs(device, s["v_V"]) for s in scheds]


def _form(family: str, i: int = 0) -> dict:
    return draw_form(family, np.random.default_rng(1000 + 17 * i + ALL.index(family)))


def _dev(out, clean) -> np.ndarray:
    return np.concatenate([o["y_um"] - c for o, c in zip(out, clean)])


def test_names():
    assert len(LIBRARY) == 10 and len(set(LIBRARY)) == 10
    assert {"thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power", "sensor_nonlinearity",
            "reversible", "interaction", "first_point", "gain_drift"} == set(LIBRARY)
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    assert not set(OUTSIDE) & set(LIBRARY)
    with pytest.raises(ValueError):
        draw_form("no_such_effect", np.random.default_rng(0))


def test_no_effect_is_clean(device, scheds, clean):
    out = simulate(device, scheds, [], seed=3, noise_um=None)
    assert len(out) == 2
    for o, c, s in zip(out, clean, scheds):
        assert np.array_equal(o["y_um"], c)
        assert np.array_equal(o["v_V"], s["v_V"])


@pytest.mark.parametrize("family", ALL)
def test_strength_zero_is_clean(device, scheds, clean, family):
    out = simulate(device, scheds, [(family, _form(family), 0.0)], seed=3, noise_um=None)
    for o, c in zip(out, clean):
        assert np.array_equal(o["y_um"], c)


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output_and_stays_physical(device, scheds, clean, family):
    swing = np.ptp(np.concatenate(clean))
    for i in range(2):  # two different forms of the mechanism
        out = simulate(device, scheds, [(family, _form(family, i), 1.0)], seed=11, noise_um=None)
        d = _dev(out, clean)
        assert np.all(np.isfinite(d))
        assert np.max(np.abs(d)) > 1e-3 * swing, (family, i)
        assert np.max(np.abs(d)) < 0.12 * swing, (family, i)


@pytest.mark.parametrize("family", ALL)
def test_effect_grows_with_strength(device, scheds, clean, family):
    form = _form(family)
    sizes = []
    for s in (0.25, 1.0, 3.0):
        out = simulate(device, scheds, [(family, form, s)], seed=11, noise_um=None)
        sizes.append(float(np.sqrt(np.mean(_dev(out, clean) ** 2))))
    assert sizes[0] < sizes[1] < sizes[2], sizes


def test_determinism(device, scheds):
    effects = [("thermal_lag", _form("thermal_lag"), 1.3), ("baseline_drift", _form("baseline_drift"), 0.7)]
    a = simulate(device, scheds, effects, seed=21, noise_um=0.05)
    b = simulate(device, scheds, effects, seed=21, noise_um=0.05)
    c = simulate(device, scheds, effects, seed=22, noise_um=0.05)
    for x, y, z in zip(a, b, c):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[key], y[key])
        assert not np.array_equal(x["y_um"], z["y_um"])


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift"])
def test_drift_realisation_independent_of_strength(device, scheds, clean, family):
    form = _form(family)
    d1 = _dev(simulate(device, scheds, [(family, form, 1.0)], seed=5, noise_um=None), clean)
    d3 = _dev(simulate(device, scheds, [(family, form, 3.0)], seed=5, noise_um=None), clean)
    assert np.max(np.abs(d1)) > 0.0
    np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-9)
    # a different seed is a different realisation of the same form
    d1b = _dev(simulate(device, scheds, [(family, form, 1.0)], seed=6, noise_um=None), clean)
    assert not np.allclose(d1, d1b)


@pytest.mark.parametrize("family", ["ambient_drift", "thermal_lag", "creep"])
def test_realisation_independent_of_strength_nonlinear(device, scheds, clean, family):
    # The response to a drift is nonlinear, but small strengths must scale it (the path is fixed by the seed).
    form = _form(family)
    d1 = _dev(simulate(device, scheds, [(family, form, 1e-4)], seed=5, noise_um=None), clean)
    d2 = _dev(simulate(device, scheds, [(family, form, 2e-4)], seed=5, noise_um=None), clean)
    big = np.abs(d1) > 1e-3 * np.max(np.abs(d1))
    if family == "ambient_drift":  # a hysteron may switch at only one of the two: compare the typical ratio
        assert np.median(d2[big] / d1[big]) == pytest.approx(2.0, rel=0.05)
    else:
        np.testing.assert_allclose(d2[big] / d1[big], 2.0, rtol=0.05)


def test_realisation_independent_of_other_mechanisms(device, scheds, clean):
    base_form = _form("baseline_drift")
    alone = _dev(simulate(device, scheds, [("baseline_drift", base_form, 1.0)], seed=9, noise_um=None), clean)
    for other in ("first_point", "creep", "thermal_lag"):
        of = _form(other)
        o1 = simulate(device, scheds, [(other, of, 1.0)], seed=9, noise_um=None)
        o2 = simulate(device, scheds, [(other, of, 1.0), ("baseline_drift", base_form, 1.0)], seed=9,
                      noise_um=None)
        diff = np.concatenate([b["y_um"] - a["y_um"] for a, b in zip(o1, o2)])
        np.testing.assert_allclose(diff, alone, rtol=1e-9, atol=1e-9)


def test_noise_and_timing_independent_of_effects(device, scheds):
    sets = [[], [("creep", _form("creep"), 1.0)], [("gain_drift", _form("gain_drift"), 2.0),
                                                     ("interaction", _form("interaction"), 1.0)]]
    noises, times = [], []
    for effects in sets:
        noisy = simulate(device, scheds, effects, seed=13, noise_um=0.1)
        quiet = simulate(device, scheds, effects, seed=13, noise_um=None)
        noises.append(np.concatenate([a["y_um"] - b["y_um"] for a, b in zip(noisy, quiet)]))
        times.append(np.concatenate([a["t_s"] for a in noisy]))
    for n, t in zip(noises[1:], times[1:]):
        np.testing.assert_allclose(n, noises[0], atol=1e-9)
        assert np.array_equal(t, times[0])
    assert 0.07 < np.std(noises[0]) < 0.13


def test_prefix_stability(device, scheds):
    effects = [("thermal_lag", _form("thermal_lag"), 1.0), ("creep", _form("creep"), 1.0)]
    third = _schedules(seed=4, n1=30, n2=30)[1]
    one = simulate(device, scheds[:1], effects, seed=17, noise_um=0.05)
    two = simulate(device, scheds, effects, seed=17, noise_um=0.05)
    three = simulate(device, scheds + [third], effects, seed=17, noise_um=0.05)
    assert len(one) == 1 and len(two) == 2 and len(three) == 3
    for key in ("t_s", "y_um", "dwell_s"):
        assert np.array_equal(one[0][key], two[0][key])
        assert np.array_equal(two[0][key], three[0][key])
        assert np.array_equal(two[1][key], three[1][key])
    for family in ("ambient_drift", "accommodation", "backlash"):
        e = [(family, _form(family), 1.0)]
        a = simulate(device, scheds[:1], e, seed=17, noise_um=0.05)
        b = simulate(device, scheds, e, seed=17, noise_um=0.05)
        assert np.array_equal(a[0]["y_um"], b[0]["y_um"])


def test_time_stamps(device, scheds):
    out = simulate(device, scheds, [], seed=1, noise_um=None)
    for o, s in zip(out, scheds):
        t = o["t_s"]
        assert np.all(np.diff(t) > 0)
        assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 1.0)
        assert t[0] == pytest.approx(o["dwell_s"][0])
        assert t[-1] == pytest.approx(np.sum(s["dwell_s"]), rel=0.02)


@pytest.mark.parametrize("family", ALL)
def test_forms_are_json_safe(device, scheds, family):
    forms = [draw_form(family, np.random.default_rng(i)) for i in range(25)]
    for f in forms:
        assert json.loads(json.dumps(f)) == f
    assert len({json.dumps(f, sort_keys=True) for f in forms}) > 1  # the form is drawn, not fixed
    f = forms[0]
    a = simulate(device, scheds, [(family, f, 1.0)], seed=2, noise_um=None)
    b = simulate(device, scheds, [(family, json.loads(json.dumps(f)), 1.0)], seed=2, noise_um=None)
    for x, y in zip(a, b):
        assert np.array_equal(x["y_um"], y["y_um"])


def test_forms_do_not_depend_on_anything_but_rng():
    for family in ALL:
        assert draw_form(family, np.random.default_rng(5)) == draw_form(family, np.random.default_rng(5))


def test_pairs_compose(device, scheds, clean):
    pairs = [("thermal_lag", "joule_power"), ("ambient_drift", "interaction"), ("creep", "sensor_nonlinearity"),
             ("first_point", "gain_drift"), ("reversible", "baseline_drift")]
    for a, b in pairs:
        out = simulate(device, scheds, [(a, _form(a), 1.0), (b, _form(b), 1.0)], seed=8, noise_um=None)
        oa = simulate(device, scheds, [(a, _form(a), 1.0)], seed=8, noise_um=None)
        d = _dev(out, clean)
        assert np.all(np.isfinite(d))
        assert not np.allclose(d, _dev(oa, clean))
