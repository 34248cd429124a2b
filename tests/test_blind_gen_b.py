"""Blind generator B: strength 0 is the clean device, determinism, every mechanism acts, realisations fixed."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_b import LIBRARY, OUTSIDE, draw_form, simulate

ALL = LIBRARY + OUTSIDE


def _walls(device):
    L = device.levels
    return device.v_min_V + (device.v_max_V - device.v_min_V) * np.arange(L + 1) / L


def _damped_oscillation(device, n_points=None, dwell=20.0, K=20):
    """Walls of the grid, visited in a damped oscillation: 0 -> L -> 0 -> L-1 -> 1 -> ..."""
    L = device.levels
    idx, lo, hi, up = [0], 0, L, True
    while lo <= hi:
        idx += list(range(idx[-1] + 1, hi + 1)) if up else list(range(idx[-1] - 1, lo - 1, -1))
        if up:
            hi -= 1
        else:
            lo += 1
        up = not up
    n = L * (L + 1) // 2 + 1 if n_points is None else n_points
    v = _walls(device)[idx[:n]]
    v = np.append(v, _walls(device)[L // 2 + 3])
    return {"v_V": v, "dwell_s": np.full(len(v), dwell), "readings": K}


def _check_run(device, rng, n=360, K=20):
    v = [float(rng.uniform(0.0, device.v_max_V))]
    while len(v) < n:
        u = rng.random()
        if u < 0.1:
            v.append(v[-1])                                         # repeated set-point
        elif u < 0.3:
            step = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-3.0, -1.0)   # millivolts to 0.1 V
            v.append(float(np.clip(v[-1] + step, 0.0, device.v_max_V)))
        else:
            v.append(float(rng.uniform(0.0, device.v_max_V)))     # up to the whole range
    return {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": K}


@pytest.fixture(scope="module")
def small():
    device = base.draw_device(7)
    schedules = [_damped_oscillation(device, n_points=110), _check_run(device, np.random.default_rng(3), n=60)]
    clean = simulate(device, schedules, [], 11, None)
    return device, schedules, clean


def _forms(family, n=1, start=0):
    return [draw_form(family, np.random.default_rng(1000 + start + k)) for k in range(n)]


def _y(runs):
    return np.concatenate([r["y_um"] for r in runs])


def test_names():
    assert set(LIBRARY) == {"thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
                            "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift"}
    assert len(LIBRARY) == 10
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    assert not set(OUTSIDE) & set(LIBRARY)


@pytest.mark.parametrize("family", ALL)
def test_forms_are_json_and_seeded(family):
    a = draw_form(family, np.random.default_rng(5))
    b = draw_form(family, np.random.default_rng(5))
    assert json.loads(json.dumps(a)) == a == b
    many = [json.dumps(draw_form(family, np.random.default_rng(k))) for k in range(8)]
    assert len(set(many)) > 1                               # a broad family, not one law


def test_strength_zero_is_clean(small):
    device, schedules, clean = small
    for run, sch in zip(clean, schedules):
        assert np.array_equal(run["y_um"], base.clean_outputs(device, sch["v_V"]))
    effects = [(f, _forms(f)[0], 0.0) for f in ALL]
    runs = simulate(device, schedules, effects, 11, None)
    for run, sch in zip(runs, schedules):
        assert np.array_equal(run["y_um"], base.clean_outputs(device, sch["v_V"]))
        assert np.array_equal(run["v_V"], sch["v_V"])
    # the noise does not depend on the effects
    noisy0 = simulate(device, schedules, [], 11, 0.05)
    noisy1 = simulate(device, schedules, [("baseline_drift", _forms("baseline_drift")[0], 1.0)], 11, 0.05)
    drift = simulate(device, schedules, [("baseline_drift", _forms("baseline_drift")[0], 1.0)], 11, None)
    np.testing.assert_allclose(_y(noisy1) - _y(drift), _y(noisy0) - _y(clean), atol=1e-12)
    resid = _y(noisy0) - _y(clean)
    assert 0.03 < np.std(resid) < 0.07


def test_logger(small):
    device, schedules, clean = small
    for run, sch in zip(clean, schedules):
        assert set(run) == {"t_s", "v_V", "y_um", "dwell_s"}
        n = len(sch["v_V"])
        assert all(len(run[k]) == n for k in run)
        assert np.all(np.diff(run["t_s"]) > 0)
        assert np.all(run["dwell_s"] >= sch["dwell_s"]) and np.all(run["dwell_s"] < sch["dwell_s"] + 1.0)
        change = run["t_s"] - run["dwell_s"]                 # set-point change times
        assert change[0] == pytest.approx(0.0)
        assert np.all(change[1:] > run["t_s"][:-1])          # the next set-point comes after the reading


def test_determinism(small):
    device, schedules, _ = small
    effects = [("thermal_lag", _forms("thermal_lag")[0], 1.5), ("gain_drift", _forms("gain_drift")[0], 1.0)]
    a = simulate(device, schedules, effects, 5, 0.02)
    b = simulate(device, schedules, effects, 5, 0.02)
    for ra, rb in zip(a, b):
        for k in ra:
            assert np.array_equal(ra[k], rb[k])
    c = simulate(device, schedules, effects, 6, 0.02)
    assert not np.array_equal(_y(a), _y(c))


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output(small, family):
    device, schedules, clean = small
    y0 = _y(clean)
    swing = float(np.ptp(y0))
    for k, form in enumerate(_forms(family, 2, start=10)):
        y1 = _y(simulate(device, schedules, [(family, form, 1.0)], 11, None))
        d1 = np.abs(y1 - y0)
        assert np.all(np.isfinite(y1))
        assert d1.max() > 1e-3 * swing, (family, form)                  # visible
        assert d1.max() < 0.08 * swing, (family, form)                  # physical: a few % of the swing
        if k == 0:                                                      # grows with the strength
            d2 = np.abs(_y(simulate(device, schedules, [(family, form, 2.0)], 11, None)) - y0)
            assert np.sqrt(np.mean(d2 ** 2)) > np.sqrt(np.mean(d1 ** 2))


def test_realisations_do_not_depend_on_strength(small):
    device, schedules, clean = small
    y0 = _y(clean)
    # additive / multiplicative sensor drifts: exactly linear in the strength
    for family in ("baseline_drift", "gain_drift"):
        form = _forms(family)[0]
        d1 = _y(simulate(device, schedules, [(family, form, 1.0)], 11, None)) - y0
        d3 = _y(simulate(device, schedules, [(family, form, 3.0)], 11, None)) - y0
        np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-12)
    # nor on the other mechanisms present: the zero's path is the same with a film effect added
    fb, fr = _forms("baseline_drift")[0], _forms("reversible")[0]
    both = _y(simulate(device, schedules, [("baseline_drift", fb, 1.0), ("reversible", fr, 1.0)], 11, None))
    rev = _y(simulate(device, schedules, [("reversible", fr, 1.0)], 11, None))
    base_only = _y(simulate(device, schedules, [("baseline_drift", fb, 1.0)], 11, None))
    np.testing.assert_allclose(both - rev, base_only - y0, atol=1e-12)


def test_ambient_path_is_drawn_before_scaling(small, monkeypatch):
    device, schedules, _ = small
    session = sys.modules["benchmarks.blind.gen_b.session"]
    seen = []
    real = session.drift_path

    def spy(components, t_end, key):
        grid, values = real(components, t_end, key)
        seen.append(values.copy())
        return grid, values

    monkeypatch.setattr(session, "drift_path", spy)
    form = _forms("ambient_drift")[0]
    simulate(device, schedules, [("ambient_drift", form, 0.5)], 11, None)
    first = list(seen)
    seen.clear()
    simulate(device, schedules, [("ambient_drift", form, 2.0), ("thermal_lag", _forms("thermal_lag")[0], 1.0)],
             11, None)
    assert len(first) == len(seen) == 2
    for a, b in zip(first, seen):
        assert np.array_equal(a, b)
    assert not np.array_equal(first[0], first[1])          # differently in every run


def test_a_full_session_simulates_both_runs():
    device = base.draw_device(2)
    schedules = [_damped_oscillation(device), _check_run(device, np.random.default_rng(9))]
    assert len(schedules[0]["v_V"]) == 467
    runs = simulate(device, schedules, [], 1, None)
    heavy = simulate(device, schedules, [("thermal_lag", _forms("thermal_lag")[0], 1.0),
                                         ("interaction", _forms("interaction")[0], 1.0)], 1, None)
    assert [r["y_um"].size for r in heavy] == [467, len(schedules[1]["v_V"])]
    assert all(np.all(np.isfinite(r["y_um"])) for r in heavy)
    assert not np.allclose(heavy[0]["y_um"], runs[0]["y_um"])
    assert runs[0]["t_s"][-1] > 2 * 3600                   # the identification run lasts hours
