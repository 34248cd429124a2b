"""Blind generator H: clean at strength 0, determinism, prefix stability, every mechanism acts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_h import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_h import mechanisms, schedules

ALL = LIBRARY + OUTSIDE


@pytest.fixture(scope="module")
def device():
    return base.draw_device(3)


@pytest.fixture(scope="module")
def session():
    return schedules.session()


@pytest.fixture(scope="module")
def short_session():
    ident = schedules.identification_schedule()
    check = schedules.check_schedule()
    cut = lambda s, n: {"v_V": s["v_V"][:n], "dwell_s": s["dwell_s"][:n], "readings": s["readings"]}
    return [cut(ident, 120), cut(check, 60)]


def _form(family, k=0):
    return json.loads(json.dumps(draw_form(family, np.random.default_rng(1000 + k))))


def _clean(device, sess):
    return [base.clean_outputs(device, s["v_V"]) for s in sess]


def test_names():
    assert set(LIBRARY) == {
        "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
        "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift"}
    assert len(LIBRARY) == 10
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    assert not set(OUTSIDE) & set(LIBRARY)


def test_schedules():
    ident = schedules.identification_schedule()
    assert ident["v_V"].size == 467
    walls = np.linspace(0.0, 6.0, 31)
    assert np.all(np.min(np.abs(ident["v_V"][:, None] - walls[None, :]), axis=1) < 1e-12)
    check = schedules.check_schedule()
    assert 340 <= check["v_V"].size <= 380
    assert check["dwell_s"].min() >= 8.0 and check["dwell_s"].max() <= 60.0
    assert np.sum(np.diff(check["v_V"]) == 0.0) > 0


def test_forms_json_safe_and_broad():
    for fam in ALL:
        kinds = set()
        for k in range(12):
            f = draw_form(fam, np.random.default_rng(k))
            assert json.loads(json.dumps(f)) == f
            kinds.add(json.dumps({key: f[key] for key in ("kind", "kernel", "process", "shape",
                                                          "alpha_law", "law", "pattern", "sense")
                                  if key in f}))
        assert len(kinds) >= 2, fam
    with pytest.raises(ValueError):
        draw_form("no_such_thing", np.random.default_rng(0))


def test_strength_zero_is_clean(device, session):
    clean = _clean(device, session)
    every = [(fam, _form(fam), 0.0) for fam in ALL]
    for effects in ([], every):
        out = simulate(device, session, effects, seed=4, noise_um=None)
        assert len(out) == 2
        for o, c in zip(out, clean):
            assert np.array_equal(o["y_um"], c)


def test_strength_zero_is_clean_each(device, short_session):
    clean = _clean(device, short_session)
    for fam in ALL:
        out = simulate(device, short_session, [(fam, _form(fam, 1), 0.0)], seed=4, noise_um=0.0)
        for o, c in zip(out, clean):
            assert np.array_equal(o["y_um"], c)


def test_logger_and_timing(device, session):
    out = simulate(device, session, [], seed=9, noise_um=None)
    for o, s in zip(out, session):
        assert set(o) == {"t_s", "v_V", "y_um", "dwell_s"}
        n = s["v_V"].size
        assert all(o[k].shape == (n,) for k in o)
        assert np.array_equal(o["v_V"], s["v_V"])
        assert np.all(np.diff(o["t_s"]) > 0)
        assert np.all(o["dwell_s"] >= s["dwell_s"])
        assert np.all(o["dwell_s"] - s["dwell_s"] < 1.0)
        change = o["t_s"] - o["dwell_s"]
        assert np.all(change[1:] > o["t_s"][:-1])  # the next set-point comes after the reading
        assert 0.0 < change[0] < 1.5
    assert out[1]["t_s"][-1] > 3600.0


def test_determinism_and_noise_independent_of_effects(device, short_session):
    eff_a = [("thermal_lag", _form("thermal_lag"), 1.0), ("baseline_drift", _form("baseline_drift"), 1.0)]
    eff_b = [("creep", _form("creep"), 2.0)]
    a1 = simulate(device, short_session, eff_a, seed=21, noise_um=0.05)
    a2 = simulate(device, short_session, eff_a, seed=21, noise_um=0.05)
    for x, y in zip(a1, a2):
        for k in x:
            assert np.array_equal(x[k], y[k])
    a0 = simulate(device, short_session, eff_a, seed=21, noise_um=None)
    b1 = simulate(device, short_session, eff_b, seed=21, noise_um=0.05)
    b0 = simulate(device, short_session, eff_b, seed=21, noise_um=None)
    c1 = simulate(device, short_session, [], seed=21, noise_um=0.05)
    for r in range(2):
        na = a1[r]["y_um"] - a0[r]["y_um"]
        nb = b1[r]["y_um"] - b0[r]["y_um"]
        assert np.allclose(na, nb, atol=1e-12, rtol=0)
        assert np.allclose(c1[r]["y_um"] - base.clean_outputs(device, short_session[r]["v_V"]), na,
                           atol=1e-12, rtol=0)
        assert 0.03 < np.std(na) < 0.07
        assert np.array_equal(a1[r]["t_s"], b1[r]["t_s"])  # timing independent of the effects
    # another seed: another realisation
    a3 = simulate(device, short_session, eff_a, seed=22, noise_um=0.05)
    assert not np.allclose(a3[0]["y_um"], a1[0]["y_um"])


@pytest.mark.parametrize("effects", [
    ["thermal_lag", "creep", "baseline_drift"],
    ["accommodation", "backlash", "gain_drift", "ambient_drift"],
    ["interaction", "first_point", "optical_contrast"],
])
def test_prefix_stability(device, short_session, effects):
    eff = [(fam, _form(fam, 3), 1.0) for fam in effects]
    extra = schedules.check_schedule(n=60, seed=99)
    two = simulate(device, short_session, eff, seed=5, noise_um=0.02)
    three = simulate(device, short_session + [extra], eff, seed=5, noise_um=0.02)
    assert len(three) == 3
    for r in range(2):
        for k in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(two[r][k], three[r][k])
    one = simulate(device, short_session[:1], eff, seed=5, noise_um=0.02)
    for k in ("t_s", "y_um", "dwell_s"):
        assert np.array_equal(one[0][k], two[0][k])


def test_every_mechanism_acts_and_grows(device, short_session):
    clean = np.concatenate(_clean(device, short_session))
    swing = np.ptp(clean)
    for k, fam in enumerate(ALL):
        for form in (_form(fam, 10 + k),):
            sizes = []
            for s in (0.5, 1.0, 2.0):
                out = simulate(device, short_session, [(fam, form, s)], seed=8, noise_um=None)
                d = np.concatenate([o["y_um"] for o in out]) - clean
                sizes.append(float(np.sqrt(np.mean(d * d))))
                assert np.all(np.isfinite(d))
            assert sizes[1] > 1e-4 * swing, (fam, form, sizes)  # (accommodation grows with use)
            assert sizes[0] < sizes[1] < sizes[2], (fam, form, sizes)
            assert sizes[1] < 0.08 * swing, (fam, form, sizes)


def test_realisations_independent_of_strength_and_of_others(device, short_session):
    clean = _clean(device, short_session)
    for fam in ("baseline_drift", "gain_drift"):
        form = _form(fam, 5)
        o1 = simulate(device, short_session, [(fam, form, 1.0)], seed=13, noise_um=None)
        o3 = simulate(device, short_session, [(fam, form, 3.0)], seed=13, noise_um=None)
        for a, b, c in zip(o1, o3, clean):
            assert np.allclose(b["y_um"] - c, 3.0 * (a["y_um"] - c), atol=1e-9)
            assert np.max(np.abs(a["y_um"] - c)) > 0
        # the two runs get different realisations
        d0, d1 = o1[0]["y_um"] - clean[0], o1[1]["y_um"] - clean[1]
        assert not np.allclose(d0[:40], d1[:40])
    # the ambient path scales with the strength, same realisation
    form = _form("ambient_drift", 5)
    tc, tr = np.arange(50.0) * 20.0 + 1.0, np.arange(50.0) * 20.0 + 20.0
    p1 = mechanisms.AmbientDrift(form, 1.0, 13).run_path(1, tc, tr)
    p2 = mechanisms.AmbientDrift(form, 2.5, 13).run_path(1, tc, tr)
    assert np.allclose(p2[0], 2.5 * p1[0]) and np.allclose(p2[1], 2.5 * p1[1])
    # other mechanisms present do not change a drift's realisation: the additive baseline drift
    # on top of the ambient drift adds exactly its own path
    fb, fa = _form("baseline_drift", 6), _form("ambient_drift", 6)
    ob = simulate(device, short_session, [("baseline_drift", fb, 1.0)], seed=13, noise_um=None)
    oa = simulate(device, short_session, [("ambient_drift", fa, 1.0)], seed=13, noise_um=None)
    ab = simulate(device, short_session, [("ambient_drift", fa, 1.0), ("baseline_drift", fb, 1.0)],
                  seed=13, noise_um=None)
    for a, b, both, c in zip(oa, ob, ab, clean):
        assert np.allclose(both["y_um"] - a["y_um"], b["y_um"] - c, atol=1e-9)


def test_invalid_effects(device, short_session):
    with pytest.raises(ValueError):
        simulate(device, short_session, [("no_such_thing", {}, 1.0)], seed=0, noise_um=None)
    with pytest.raises(ValueError):
        simulate(device, short_session, [("creep", _form("creep"), -1.0)], seed=0, noise_um=None)


def test_a_noise_free_session_simulates_both_runs(device, session):
    eff = [("thermal_lag", _form("thermal_lag", 7), 1.0), ("interaction", _form("interaction", 7), 1.0)]
    out = simulate(device, session, eff, seed=1, noise_um=None)
    assert [o["y_um"].size for o in out] == [467, 360]
