"""Tests of the blind generator ``benchmarks.blind.gen_s`` (the electronics bench's simulator)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_s import FAMILIES, LIBRARY, OUTSIDE, draw_form, simulate

SPEC_LIBRARY = {
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
}


def _ident(n: int = 120, levels: int = 30, v_max: float = 6.0):
    """A short damped oscillation on the grid's walls, 20 s dwells."""
    h = v_max / levels
    idx = []
    for j in range(n):
        amp = levels * (1.0 - j / n)
        idx.append(round(levels / 2 + amp / 2) if j % 2 == 0 else round(levels / 2 - amp / 2))
    return {"v_V": np.array(idx, dtype=float) * h, "dwell_s": np.full(n, 20.0), "readings": 8}


def _check(seed: int, n: int = 80, v_max: float = 6.0):
    """Random reversals, steps from millivolts to the whole range, repeats, dwells 8..60 s."""
    rng = np.random.default_rng(seed)
    v = [0.0]
    for _ in range(n):
        r = rng.uniform()
        if r < 0.1:
            v.append(v[-1])
        elif r < 0.4:
            v.append(float(np.clip(v[-1] + rng.normal(0.0, 0.01), 0.0, v_max)))
        else:
            v.append(float(rng.uniform(0.0, v_max)))
    return {"v_V": np.array(v[1:]), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": 8}


SCHEDULES = [_ident(), _check(1)]


@pytest.fixture(scope="module")
def device():
    return base.draw_device(7)


@pytest.fixture(scope="module")
def clean(device):
    return [base.clean_outputs(device, s["v_V"]) for s in SCHEDULES]


def _form(family: str, k: int = 0) -> dict:
    return draw_form(family, np.random.default_rng(1000 + 17 * k + FAMILIES.index(family)))


def _y(out) -> np.ndarray:
    return np.concatenate([o["y_um"] for o in out])


def test_names_match_the_spec():
    assert set(LIBRARY) == SPEC_LIBRARY and len(LIBRARY) == 10
    assert {"backlash", "accommodation"} <= set(OUTSIDE) and len(OUTSIDE) == 3
    assert not set(OUTSIDE) & SPEC_LIBRARY


@pytest.mark.parametrize("seed", [0, 3])
def test_strength_zero_equals_clean_device(seed):
    dev = base.draw_device(seed)
    effects = [(f, _form(f), 0.0) for f in FAMILIES]
    for eff in ([], effects):
        out = simulate(dev, SCHEDULES, eff, 11, None)
        for o, s in zip(out, SCHEDULES):
            assert np.array_equal(o["y_um"], base.clean_outputs(dev, s["v_V"]))
            assert np.array_equal(o["v_V"], s["v_V"])


def test_determinism_and_seed(device):
    eff = [("baseline_drift", _form("baseline_drift"), 1.0), ("creep", _form("creep"), 1.0)]
    a = simulate(device, SCHEDULES, eff, 5, 0.05)
    b = simulate(device, SCHEDULES, eff, 5, 0.05)
    for oa, ob in zip(a, b):
        assert oa.keys() == ob.keys()
        for k in oa:
            assert np.array_equal(oa[k], ob[k])
    c = simulate(device, SCHEDULES, eff, 6, 0.05)
    assert not np.array_equal(_y(a), _y(c))


@pytest.mark.parametrize("family", FAMILIES)
def test_every_mechanism_changes_the_output(device, clean, family):
    swing = np.ptp(np.concatenate(clean))
    for k in range(3):
        out = simulate(device, SCHEDULES, [(family, _form(family, k), 1.0)], 2, None)
        dev = np.abs(_y(out) - np.concatenate(clean))
        assert np.all(np.isfinite(dev))
        assert dev.max() > 1e-3 * swing, (family, k)
        assert dev.max() < 0.1 * swing, (family, k)  # physical: a few percent at strength 1


@pytest.mark.parametrize("family", FAMILIES)
def test_effect_grows_with_strength(device, clean, family):
    ref = np.concatenate(clean)
    rms = [np.sqrt(np.mean((_y(simulate(device, SCHEDULES, [(family, _form(family), s)], 4, None)) - ref) ** 2))
           for s in (0.25, 1.0, 4.0)]
    assert rms[0] < rms[1] < rms[2], rms


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift"])
def test_drift_realisation_does_not_depend_on_strength(device, clean, family):
    ref = np.concatenate(clean)
    d1 = _y(simulate(device, SCHEDULES, [(family, _form(family), 1.0)], 9, None)) - ref
    d3 = _y(simulate(device, SCHEDULES, [(family, _form(family), 3.0)], 9, None)) - ref
    assert np.abs(d1).max() > 0
    np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-9)


def test_ambient_realisation_does_not_depend_on_strength(device, clean):
    ref = np.concatenate(clean)
    form = _form("ambient_drift")
    d1 = _y(simulate(device, SCHEDULES, [("ambient_drift", form, 0.2)], 9, None)) - ref
    d2 = _y(simulate(device, SCHEDULES, [("ambient_drift", form, 0.4)], 9, None)) - ref
    d_other = _y(simulate(device, SCHEDULES, [("ambient_drift", form, 0.4)], 10, None)) - ref
    assert np.abs(d1).max() > 0
    c_same = np.corrcoef(d1, d2)[0, 1]
    c_other = np.corrcoef(d2, d_other)[0, 1]
    assert c_same > 0.9 and c_same > c_other + 0.1


def test_realisations_do_not_depend_on_other_mechanisms(device, clean):
    ref = np.concatenate(clean)
    drift = ("baseline_drift", _form("baseline_drift"), 1.0)
    other = ("reversible", _form("reversible"), 1.0)
    alone = _y(simulate(device, SCHEDULES, [drift], 3, None)) - ref
    both = _y(simulate(device, SCHEDULES, [other, drift], 3, None))
    rev = _y(simulate(device, SCHEDULES, [other], 3, None))
    np.testing.assert_allclose(both - rev, alone, rtol=0, atol=1e-9)
    # the noise does not depend on the effects either
    n1 = _y(simulate(device, SCHEDULES, [other], 3, 0.1)) - rev
    n0 = _y(simulate(device, SCHEDULES, [], 3, 0.1)) - ref
    np.testing.assert_allclose(n1, n0, rtol=0, atol=1e-9)
    assert 0.05 < np.std(n0) < 0.2


def test_prefix_stability(device):
    extra = _check(5, n=30)
    eff = [(f, _form(f), 0.8) for f in
           ("thermal_lag", "creep", "baseline_drift", "ambient_drift", "gain_drift", "backlash", "accommodation")]
    one = simulate(device, SCHEDULES[:1], eff, 8, 0.1)
    two = simulate(device, SCHEDULES, eff, 8, 0.1)
    three = simulate(device, SCHEDULES + [extra], eff, 8, 0.1)
    assert len(three) == 3
    for shorter, longer in ((one, two), (two, three)):
        for a, b in zip(shorter, longer):
            for k in a:
                assert np.array_equal(a[k], b[k]), k


def test_time_stamps(device):
    out_clean = simulate(device, SCHEDULES, [], 4, None)
    out_eff = simulate(device, SCHEDULES, [("creep", _form("creep"), 2.0)], 4, None)
    for o, oe, s in zip(out_clean, out_eff, SCHEDULES):
        assert np.array_equal(o["t_s"], oe["t_s"])
        assert np.all(np.diff(o["t_s"]) > s["dwell_s"][1:])
        assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 1.0)
        assert o["t_s"][0] == pytest.approx(o["dwell_s"][0])


@pytest.mark.parametrize("family", FAMILIES)
def test_forms_are_json_safe_and_deterministic(device, family):
    for k in range(6):
        form = _form(family, k)
        assert form == _form(family, k)
        again = json.loads(json.dumps(form))
        assert again == form
    out_a = simulate(device, SCHEDULES[:1], [(family, form, 1.0)], 1, None)
    out_b = simulate(device, SCHEDULES[:1], [(family, again, 1.0)], 1, None)
    assert np.array_equal(out_a[0]["y_um"], out_b[0]["y_um"])


def test_bad_input_is_refused(device):
    with pytest.raises(ValueError):
        simulate(device, SCHEDULES, [("no_such_thing", {}, 1.0)], 0, None)
    with pytest.raises(ValueError):
        simulate(device, SCHEDULES, [("creep", _form("creep"), -1.0)], 0, None)
    with pytest.raises(ValueError):
        draw_form("no_such_thing", np.random.default_rng(0))
