"""Blind generator L: API, clean limit, determinism, every mechanism acts, independent realisations, prefix stability."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_l import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_l import schedules as S

ALL = LIBRARY + OUTSIDE
SPEC_LIBRARY = {
    "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
    "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
}


@pytest.fixture(scope="module")
def device():
    return base.draw_device(11)


@pytest.fixture(scope="module")
def short():
    return S.short(n=40, seed=3)


def _forms(family, n=3, start=0):
    return [draw_form(family, np.random.default_rng(start + j)) for j in range(n)]


def _y(out):
    return np.concatenate([o["y_um"] for o in out])


def test_api_names_and_forms():
    assert set(LIBRARY) == SPEC_LIBRARY and len(LIBRARY) == 10
    assert {"backlash", "accommodation"} <= set(OUTSIDE) and len(OUTSIDE) == 3
    assert not set(OUTSIDE) & set(LIBRARY)
    for fam in ALL:
        for j in range(20):
            f = draw_form(fam, np.random.default_rng(j))
            assert json.loads(json.dumps(f)) == f
            assert f == draw_form(fam, np.random.default_rng(j))
    with pytest.raises(ValueError):
        draw_form("no_such_effect", np.random.default_rng(0))


def test_strength_zero_is_clean_device_bit_for_bit(device, short):
    effects = [(fam, draw_form(fam, np.random.default_rng(5)), 0.0) for fam in ALL]
    for eff in ([], effects):
        out = simulate(device, short, eff, seed=4, noise_um=None)
        for o, sch in zip(out, short):
            assert np.array_equal(o["y_um"], base.clean_outputs(device, sch["v_V"]))
            assert np.array_equal(o["v_V"], sch["v_V"])


def test_a_full_clean_session_is_the_base_device(device):
    sess = S.session(0)
    out = simulate(device, sess, [], seed=1, noise_um=None)
    for o, sch in zip(out, sess):
        assert np.array_equal(o["y_um"], base.clean_outputs(device, sch["v_V"]))
        assert np.all(np.diff(o["t_s"]) > 0)
        # the logger's dwell: the real time from the set-point change to the (mid-burst) reading
        assert np.all(o["dwell_s"] >= sch["dwell_s"]) and np.all(o["dwell_s"] < sch["dwell_s"] + 1.0)
        assert o["t_s"][0] == pytest.approx(o["dwell_s"][0])
        assert 1.5 * 3600 < o["t_s"][-1] < 5 * 3600


def test_determinism(device, short):
    eff = [("thermal_lag", _forms("thermal_lag")[0], 1.0), ("gain_drift", _forms("gain_drift")[1], 2.0),
           ("backlash", _forms("backlash")[2], 0.5)]
    a = simulate(device, short, eff, seed=9, noise_um=0.05)
    b = simulate(device, short, eff, seed=9, noise_um=0.05)
    for x, y in zip(a, b):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[key], y[key])
    c = simulate(device, short, eff, seed=10, noise_um=0.05)
    assert not np.array_equal(_y(a), _y(c))


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(device, short, family):
    clean = _y(simulate(device, short, [], seed=2, noise_um=None))
    swing = clean.max() - clean.min()
    for form in _forms(family, n=3, start=17):
        y = _y(simulate(device, short, [(family, form, 1.0)], seed=2, noise_um=None))
        dev = np.max(np.abs(y - clean))
        assert 1e-3 * swing < dev < 0.1 * swing, (family, form, dev / swing)
        y3 = _y(simulate(device, short, [(family, form, 3.0)], seed=2, noise_um=None))
        assert np.max(np.abs(y3 - clean)) > dev  # grows with the strength


def test_realisations_independent_of_strength_and_of_other_mechanisms(device, short):
    clean = _y(simulate(device, short, [], seed=6, noise_um=None))
    for fam in ("baseline_drift", "gain_drift"):
        for form in _forms(fam, n=3, start=40):
            d1 = _y(simulate(device, short, [(fam, form, 1.0)], seed=6, noise_um=None)) - clean
            d2 = _y(simulate(device, short, [(fam, form, 2.5)], seed=6, noise_um=None)) - clean
            np.testing.assert_allclose(d2, 2.5 * d1, rtol=1e-9, atol=1e-9)
    # the room's drift: the same path at every strength (small strengths: nearly linear response)
    form = _forms("ambient_drift", n=1, start=3)[0]
    d1 = _y(simulate(device, short, [("ambient_drift", form, 0.2)], seed=6, noise_um=None)) - clean
    d2 = _y(simulate(device, short, [("ambient_drift", form, 0.4)], seed=6, noise_um=None)) - clean
    assert np.corrcoef(d1, d2)[0, 1] > 0.9
    # an additive drift's realisation does not change when another mechanism is present
    fb = _forms("baseline_drift", n=1, start=8)[0]
    fr = _forms("reversible", n=1, start=8)[0]
    db = _y(simulate(device, short, [("baseline_drift", fb, 1.0)], seed=6, noise_um=None)) - clean
    dr = _y(simulate(device, short, [("reversible", fr, 1.0)], seed=6, noise_um=None)) - clean
    both = _y(simulate(device, short, [("reversible", fr, 1.0), ("baseline_drift", fb, 1.0)],
                       seed=6, noise_um=None)) - clean
    np.testing.assert_allclose(both, db + dr, atol=1e-9)
    # the noise and the time stamps do not depend on the effects
    n0 = simulate(device, short, [], seed=6, noise_um=0.1)
    for eff in ([("creep", _forms("creep")[0], 1.0)], [("interaction", _forms("interaction")[0], 2.0)]):
        quiet = simulate(device, short, eff, seed=6, noise_um=None)
        noisy = simulate(device, short, eff, seed=6, noise_um=0.1)
        np.testing.assert_allclose(_y(noisy) - _y(quiet), _y(n0) - clean, atol=1e-12)
        for a, b in zip(noisy, n0):
            assert np.array_equal(a["t_s"], b["t_s"])


def test_prefix_stability(device, short):
    third = S.check(seed=8, n=30)
    effects = [(fam, draw_form(fam, np.random.default_rng(21)), 1.0)
               for fam in ("thermal_lag", "ambient_drift", "accommodation", "creep", "backlash",
                           "gain_drift", "baseline_drift", "first_point")]
    for eff in ([], effects, [("interaction", _forms("interaction")[0], 1.0)]):
        two = simulate(device, short, eff, seed=13, noise_um=0.05)
        three = simulate(device, short + [third], eff, seed=13, noise_um=0.05)
        assert len(three) == 3
        for a, b in zip(two, three[:2]):
            for key in ("t_s", "v_V", "y_um", "dwell_s"):
                assert np.array_equal(a[key], b[key])
