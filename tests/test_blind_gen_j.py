"""Tests of blind generator J (benchmarks/blind/gen_j): the rules of benchmarks/blind/SPEC.md."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_j as G

ALL = G.LIBRARY + G.OUTSIDE
DRIFTS = ("baseline_drift", "ambient_drift", "gain_drift")


def _id_run(step_levels: int = 3) -> dict:
    """A short damped oscillation on the grid's walls (0.2 V grid), 20 s dwells."""
    lo, hi, cur, up, seq = 0, 30, 0, True, [0]
    while hi - lo > step_levels:
        if up:
            seq += list(range(cur + step_levels, hi + 1, step_levels))
            cur = seq[-1]
            lo += step_levels
        else:
            seq += list(range(cur - step_levels, lo - 1, -step_levels))
            cur = seq[-1]
            hi -= step_levels
        up = not up
    v = np.array(seq, dtype=float) * 0.2
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 8}


def _check_run(seed: int, n: int = 60) -> dict:
    rng = np.random.default_rng(seed)
    v = [float(rng.uniform(0.0, 6.0))]
    while len(v) < n:
        if rng.uniform() < 0.1:
            v.append(v[-1])
            continue
        step = float(np.exp(rng.uniform(np.log(0.002), np.log(6.0))))
        v.append(float(np.clip(v[-1] + rng.choice([-1.0, 1.0]) * step, 0.0, 6.0)))
    return {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": 8}


SESSION = [_id_run(), _check_run(1)]
DEVICE = base.draw_device(11)
CLEAN = [base.clean_outputs(DEVICE, s["v_V"]) for s in SESSION]
SWING = float(np.ptp(np.concatenate(CLEAN)))


def _form(family: str, k: int = 0) -> dict:
    return G.draw_form(family, np.random.default_rng(1000 + 17 * k + ALL.index(family)))


def _y(out) -> np.ndarray:
    return np.concatenate([o["y_um"] for o in out])


def test_names():
    assert set(G.LIBRARY) == {
        "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power", "sensor_nonlinearity",
        "reversible", "interaction", "first_point", "gain_drift"}
    assert set(G.OUTSIDE) == {"backlash", "accommodation", "metal_plasticity"}
    with pytest.raises(ValueError):
        G.draw_form("nonsense", np.random.default_rng(0))


@pytest.mark.parametrize("family", ALL)
def test_forms_json_safe_and_reproducible(family):
    for k in range(5):
        a, b = _form(family, k), _form(family, k)
        assert json.loads(json.dumps(a)) == a
        assert a == b


def test_no_effect_is_clean():
    out = G.simulate(DEVICE, SESSION, [], 3, None)
    for o, c, s in zip(out, CLEAN, SESSION):
        assert np.array_equal(o["y_um"], c)
        assert np.array_equal(o["v_V"], s["v_V"])


@pytest.mark.parametrize("family", ALL)
def test_strength_zero_is_clean(family):
    out = G.simulate(DEVICE, SESSION, [(family, _form(family), 0.0)], 3, None)
    for o, c in zip(out, CLEAN):
        assert np.array_equal(o["y_um"], c)


def test_all_at_zero_is_clean():
    effects = [(f, _form(f), 0.0) for f in ALL]
    out = G.simulate(DEVICE, SESSION, effects, 8, None)
    for o, c in zip(out, CLEAN):
        assert np.array_equal(o["y_um"], c)


@pytest.mark.parametrize("family", ALL)
def test_deterministic(family):
    effects = [(family, _form(family), 1.3)]
    a = G.simulate(DEVICE, SESSION, effects, 5, 0.02)
    b = G.simulate(DEVICE, SESSION, effects, 5, 0.02)
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for key in x:
            assert np.array_equal(x[key], y[key])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(family):
    for k in range(3):
        out = G.simulate(DEVICE, SESSION, [(family, _form(family, k), 1.0)], k, None)
        gap = np.abs(_y(out) - np.concatenate(CLEAN))
        assert gap.max() > 1e-3 * SWING, (family, k, gap.max())
        # physical size at strength 1: a few percent of the swing at most
        assert gap.max() < 0.06 * SWING, (family, k, gap.max() / SWING)


@pytest.mark.parametrize("family", ALL)
def test_effect_grows_with_strength(family):
    clean = np.concatenate(CLEAN)
    rms = [np.sqrt(np.mean((_y(G.simulate(DEVICE, SESSION, [(family, _form(family), s)], 2, None)) - clean) ** 2))
           for s in (0.3, 1.0, 3.0)]
    assert rms[0] < rms[1] < rms[2], rms


@pytest.mark.parametrize("family", ALL)
def test_prefix_stability(family):
    """A session with one more run appended gives exactly the same first runs (readings and time stamps)."""
    effects = [(family, _form(family, 1), 1.0)]
    runs = SESSION + [_check_run(9, 30)]
    one = G.simulate(DEVICE, runs[:1], effects, 4, 0.03)
    two = G.simulate(DEVICE, runs[:2], effects, 4, 0.03)
    three = G.simulate(DEVICE, runs, effects, 4, 0.03)
    for short, longer in ((one, two), (two, three)):
        for a, b in zip(short, longer):
            for key in a:
                assert np.array_equal(a[key], b[key]), key


def test_baseline_realisation_independent_of_strength_and_of_other_mechanisms():
    f = _form("baseline_drift")
    clean = np.concatenate(CLEAN)
    d1 = _y(G.simulate(DEVICE, SESSION, [("baseline_drift", f, 1.0)], 6, None)) - clean
    d3 = _y(G.simulate(DEVICE, SESSION, [("baseline_drift", f, 3.0)], 6, None)) - clean
    assert np.allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-9)
    other = ("first_point", _form("first_point"), 1.0)
    with_other = _y(G.simulate(DEVICE, SESSION, [("baseline_drift", f, 1.0), other], 6, None))
    other_only = _y(G.simulate(DEVICE, SESSION, [other], 6, None))
    assert np.allclose(with_other - other_only, d1, rtol=1e-9, atol=1e-9)
    # a different seed is a different realisation
    d_other_seed = _y(G.simulate(DEVICE, SESSION, [("baseline_drift", f, 1.0)], 7, None)) - clean
    assert not np.allclose(d_other_seed, d1)


def test_gain_realisation_independent_of_strength():
    f = _form("gain_drift")
    clean = np.concatenate(CLEAN)
    ok = np.abs(clean) > 0.05 * SWING
    r1 = np.log(_y(G.simulate(DEVICE, SESSION, [("gain_drift", f, 1.0)], 6, None))[ok] / clean[ok])
    r2 = np.log(_y(G.simulate(DEVICE, SESSION, [("gain_drift", f, 2.5)], 6, None))[ok] / clean[ok])
    assert np.allclose(r2, 2.5 * r1, rtol=1e-7, atol=1e-12)


def test_ambient_realisation_independent_of_strength():
    """The room's path is drawn from the seed then scaled: small strengths give proportional gaps."""
    f = _form("ambient_drift")
    clean = np.concatenate(CLEAN)
    d1 = _y(G.simulate(DEVICE, SESSION, [("ambient_drift", f, 1.0)], 6, None)) - clean
    d2 = _y(G.simulate(DEVICE, SESSION, [("ambient_drift", f, 1.5)], 6, None)) - clean
    assert np.corrcoef(d1, d2)[0, 1] > 0.9
    assert np.sum(np.abs(d2)) > np.sum(np.abs(d1))


@pytest.mark.parametrize("family", DRIFTS)
def test_drift_path_is_strength_free(family):
    from benchmarks.blind.gen_j.drifts import drift_path

    f = _form(family)
    g1, p1 = drift_path(f, family, 12, 0, 9000.0, 0.0)
    g2, p2 = drift_path(f, family, 12, 0, 9000.0, 0.0)
    _, p3 = drift_path(f, family, 12, 1, 9000.0, 0.0)
    assert np.array_equal(p1, p2) and np.array_equal(g1, g2)
    assert not np.array_equal(p1, p3)  # differently in every run
    assert np.all(np.isfinite(p1)) and np.max(np.abs(p1)) < 20.0


def test_noise_independent_of_effects():
    n0 = G.simulate(DEVICE, SESSION, [], 21, None)
    n1 = G.simulate(DEVICE, SESSION, [], 21, 0.05)
    e0 = G.simulate(DEVICE, SESSION, [("creep", _form("creep"), 2.0)], 21, None)
    e1 = G.simulate(DEVICE, SESSION, [("creep", _form("creep"), 2.0)], 21, 0.05)
    noise = _y(n1) - _y(n0)
    assert np.allclose(_y(e1) - _y(e0), noise, atol=1e-12)
    assert 0.035 < np.std(noise) < 0.065
    for a, b in zip(n0, e1):
        assert np.array_equal(a["t_s"], b["t_s"]) and np.array_equal(a["dwell_s"], b["dwell_s"])


def test_logger_timing():
    out = G.simulate(DEVICE, SESSION, [], 0, None)
    for o, s in zip(out, SESSION):
        assert np.all(np.diff(o["t_s"]) > 0)
        assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 0.5)
        assert o["t_s"][0] == pytest.approx(o["dwell_s"][0])
        assert o["t_s"][-1] == pytest.approx(np.sum(s["dwell_s"]), rel=0.02)


def test_pairs_compose():
    a, b = "thermal_lag", "sensor_nonlinearity"
    out = G.simulate(DEVICE, SESSION, [(a, _form(a), 1.0), (b, _form(b), 1.0)], 3, 0.01)
    assert all(np.all(np.isfinite(o["y_um"])) for o in out)
    with pytest.raises(ValueError):
        G.simulate(DEVICE, SESSION, [(a, _form(a), -1.0)], 3, None)
