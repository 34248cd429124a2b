"""Tests of the blind generator ``benchmarks.blind.gen_m`` (its own rules only; fast)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_m import LIBRARY, OUTSIDE, draw_form, simulate

ALL = LIBRARY + OUTSIDE


def _ident(levels: int = 30, v_max: float = 6.0, points: int = 160) -> dict:
    """The start of a damped oscillation stepping along the grid's walls, 20 s dwells."""
    walls = np.linspace(0.0, v_max, levels + 1)
    seq, lo, hi, cur, up = [], 0, levels, 0, True
    while lo <= hi and len(seq) < points:
        seq += list(range(cur + 1, hi + 1)) if up else list(range(cur - 1, lo - 1, -1))
        cur = hi if up else lo
        lo, hi = (lo + 1, hi) if up else (lo, hi - 1)
        up = not up
    v = walls[seq[:points]]
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 8}


def _check(seed: int, n: int = 110, v_max: float = 6.0) -> dict:
    """Random reversals, steps from mV to the whole range, 8-60 s dwells, some repeated set-points."""
    rng = np.random.default_rng(seed)
    v, cur = [], 0.0
    while len(v) < n:
        target = rng.uniform(0.0, v_max)
        for s in np.linspace(cur, target, int(rng.integers(1, 6)) + 1)[1:]:
            v.append(float(np.clip(s + rng.normal(0.0, 0.003), 0.0, v_max)))
            if rng.uniform() < 0.1:
                v.append(v[-1])
        cur = v[-1]
    v = np.array(v[:n])
    return {"v_V": v, "dwell_s": rng.uniform(8.0, 60.0, n), "readings": 8}


DEVICE = base.draw_device(4)
SCHEDULES = [_ident(), _check(1)]


def _forms(seed: int) -> dict:
    rng = np.random.default_rng(seed)
    return {f: draw_form(f, rng) for f in ALL}


FORMS = _forms(2024)


def _swing(outputs) -> float:
    return float(np.ptp(np.concatenate([o["y_um"] for o in outputs])))


@pytest.fixture(scope="module")
def clean():
    return simulate(DEVICE, SCHEDULES, [], 7, None)


def test_names_and_forms_are_json_safe():
    assert len(LIBRARY) == 10 and len(OUTSIDE) == 3
    assert OUTSIDE[:2] == ("backlash", "accommodation")
    rng = np.random.default_rng(0)
    for fam in ALL:
        for _ in range(5):
            form = draw_form(fam, rng)
            assert json.loads(json.dumps(form)) == form
    with pytest.raises(ValueError):
        draw_form("no_such_effect", rng)


@pytest.mark.parametrize("seed", [0, 1])
def test_strength_zero_is_the_clean_device(seed):
    device = base.draw_device(seed)
    forms = _forms(seed)
    effects = [(f, forms[f], 0.0) for f in ALL]
    for effs in ([], effects):
        out = simulate(device, SCHEDULES, effs, 3, None)
        assert len(out) == len(SCHEDULES)
        for o, s in zip(out, SCHEDULES):
            assert np.array_equal(o["y_um"], base.clean_outputs(device, s["v_V"]))
            assert np.array_equal(o["v_V"], s["v_V"])
            assert o["t_s"].shape == o["dwell_s"].shape == s["v_V"].shape
            assert np.all(np.diff(o["t_s"]) > 0) and np.all(o["dwell_s"] >= s["dwell_s"])


def test_determinism():
    effects = [("creep", FORMS["creep"], 1.0), ("baseline_drift", FORMS["baseline_drift"], 0.7),
               ("nucleation_kinetics", FORMS["nucleation_kinetics"], 1.3)]
    a = simulate(DEVICE, SCHEDULES, effects, 11, 0.05)
    b = simulate(DEVICE, SCHEDULES, effects, 11, 0.05)
    c = simulate(DEVICE, SCHEDULES, effects, 12, 0.05)
    for x, y in zip(a, b):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[key], y[key])
    assert not np.array_equal(a[1]["y_um"], c[1]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(family, clean):
    swing = _swing(clean)
    for seed in (2024, 5):
        form = FORMS[family] if seed == 2024 else _forms(seed)[family]
        out = simulate(DEVICE, SCHEDULES, [(family, form, 1.0)], 7, None)
        dev = np.concatenate([o["y_um"] - c["y_um"] for o, c in zip(out, clean)])
        assert np.max(np.abs(dev)) > 2e-3 * swing, (family, form)
        assert np.max(np.abs(dev)) < 0.12 * swing, (family, form)  # physical: a few percent


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift"])
def test_drift_realisation_independent_of_strength(family, clean):
    d1 = [o["y_um"] - c["y_um"] for o, c in zip(simulate(DEVICE, SCHEDULES, [(family, FORMS[family], 1.0)], 5, None), clean)]
    d3 = [o["y_um"] - c["y_um"] for o, c in zip(simulate(DEVICE, SCHEDULES, [(family, FORMS[family], 3.0)], 5, None), clean)]
    for a, b in zip(d1, d3):
        assert np.max(np.abs(a)) > 0
        np.testing.assert_allclose(b, 3.0 * a, rtol=1e-9, atol=1e-12)


def test_ambient_realisation_independent_of_strength():
    # below the transition the grains do not move: only the beam's own bimorph bending shows the path
    form = dict(FORMS["ambient_drift"], bimorph=0.6)
    low = [{"v_V": np.linspace(0.2, 2.0, 60), "dwell_s": np.full(60, 30.0), "readings": 8}]
    clean = simulate(DEVICE, low, [], 5, None)[0]["y_um"]
    d1 = simulate(DEVICE, low, [("ambient_drift", form, 1.0)], 5, None)[0]["y_um"] - clean
    d2 = simulate(DEVICE, low, [("ambient_drift", form, 2.0)], 5, None)[0]["y_um"] - clean
    assert np.max(np.abs(d1)) > 0
    np.testing.assert_allclose(d2, 2.0 * d1, rtol=1e-9, atol=1e-12)


def test_realisation_independent_of_other_mechanisms(clean):
    """Additive mechanisms compose additively: the drift's path is the same with another mechanism present."""
    fb, ff = FORMS["baseline_drift"], FORMS["first_point"]
    both = simulate(DEVICE, SCHEDULES, [("first_point", ff, 1.0), ("baseline_drift", fb, 1.0)], 9, None)
    only_b = simulate(DEVICE, SCHEDULES, [("baseline_drift", fb, 1.0)], 9, None)
    only_f = simulate(DEVICE, SCHEDULES, [("first_point", ff, 1.0)], 9, None)
    for x, b, f, c in zip(both, only_b, only_f, clean):
        np.testing.assert_allclose(x["y_um"] - c["y_um"], (b["y_um"] - c["y_um"]) + (f["y_um"] - c["y_um"]),
                                   atol=1e-10)


def test_noise_independent_of_effects():
    e1 = [("creep", FORMS["creep"], 1.0)]
    e2 = [("thermal_lag", FORMS["thermal_lag"], 2.0), ("gain_drift", FORMS["gain_drift"], 1.0)]
    n1 = [a["y_um"] - b["y_um"] for a, b in zip(simulate(DEVICE, SCHEDULES, e1, 3, 0.1), simulate(DEVICE, SCHEDULES, e1, 3, None))]
    n2 = [a["y_um"] - b["y_um"] for a, b in zip(simulate(DEVICE, SCHEDULES, e2, 3, 0.1), simulate(DEVICE, SCHEDULES, e2, 3, None))]
    for a, b in zip(n1, n2):
        np.testing.assert_allclose(a, b, atol=1e-10)
        assert 0.05 < np.std(a) < 0.2


def test_prefix_stability():
    effects = [("thermal_lag", FORMS["thermal_lag"], 1.0), ("creep", FORMS["creep"], 1.0),
               ("backlash", FORMS["backlash"], 1.0), ("accommodation", dict(FORMS["accommodation"], pattern="uniform"), 1.0),
               ("ambient_drift", FORMS["ambient_drift"], 1.0)]
    two = simulate(DEVICE, SCHEDULES, effects, 21, 0.05)
    three = simulate(DEVICE, SCHEDULES + [_check(9, n=40)], effects, 21, 0.05)
    assert len(three) == 3
    for a, b in zip(two, three[:2]):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(a[key], b[key])


def test_strength_grows_the_effect(clean):
    for family in ("thermal_lag", "interaction", "sensor_nonlinearity", "nucleation_kinetics"):
        rms = []
        for s in (0.5, 1.0, 2.0):
            out = simulate(DEVICE, SCHEDULES, [(family, FORMS[family], s)], 7, None)
            rms.append(np.sqrt(np.mean(np.concatenate([o["y_um"] - c["y_um"] for o, c in zip(out, clean)]) ** 2)))
        assert rms[0] < rms[1] < rms[2], family
