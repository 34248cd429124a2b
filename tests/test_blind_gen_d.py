"""Blind generator D (benchmarks/blind/gen_d): clean limit, determinism, every mechanism, sizes, speed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_d as G
from benchmarks.blind.gen_d import drift
from benchmarks.blind.gen_d.streams import stream

ALL = G.LIBRARY + G.OUTSIDE


def _id_run(levels: int = 30, v_max: float = 6.0, points: int = 467) -> dict:
    """A damped oscillation on the grid's walls (nested loops), 20 s dwells."""
    walls = np.linspace(0.0, v_max, levels + 1)
    seq: list[int] = []
    lo, hi, up = 0, levels, True
    while hi > lo and len(seq) < points:
        if up:
            seq += list(range(lo + 1, hi + 1))
            lo += 1
        else:
            seq += list(range(hi - 1, lo - 1, -1))
            hi -= 1
        up = not up
    seq = (seq + [seq[-1]] * points)[:points]
    v = walls[np.array(seq)]
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 8}


def _check_run(seed: int, points: int = 360, v_max: float = 6.0) -> dict:
    """Random reversals, steps from millivolts to the whole range, dwells 8-60 s, some repeats."""
    rng = np.random.default_rng(seed)
    v = [float(rng.uniform(0.0, v_max))]
    for _ in range(points - 1):
        u = rng.random()
        if u < 0.1:
            v.append(v[-1])
        elif u < 0.4:
            v.append(float(np.clip(v[-1] + rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-3, 0), 0.0, v_max)))
        else:
            v.append(float(rng.uniform(0.0, v_max)))
    return {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, points), "readings": 8}


FULL = [_id_run(), _check_run(1)]
# A shorter session (fewer points, same kind of runs) for the many simulations below.
SHORT = [_id_run(points=160), _check_run(2, points=90)]


@pytest.fixture(scope="module")
def device():
    return base.draw_device(17)


@pytest.fixture(scope="module")
def clean_short(device):
    return [base.clean_outputs(device, s["v_V"]) for s in SHORT]


def _y(runs) -> np.ndarray:
    return np.concatenate([r["y_um"] for r in runs])


def _form(family: str, k: int = 0) -> dict:
    return G.draw_form(family, np.random.default_rng(1000 + 7 * k + ALL.index(family)))


def test_names():
    assert set(G.LIBRARY) == {
        "thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
        "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift",
    }
    assert G.OUTSIDE[:2] == ("backlash", "accommodation") and len(G.OUTSIDE) == 3
    assert not set(G.LIBRARY) & set(G.OUTSIDE)


@pytest.mark.parametrize("family", ALL)
def test_forms_are_json_safe_and_random(family):
    forms = [G.draw_form(family, np.random.default_rng(k)) for k in range(6)]
    for f in forms:
        assert json.loads(json.dumps(f)) == f
    assert len({json.dumps(f, sort_keys=True) for f in forms}) > 1
    assert G.draw_form(family, np.random.default_rng(3)) == forms[3]


def test_unknown_family_rejected(device):
    with pytest.raises(ValueError):
        G.draw_form("nonsense", np.random.default_rng(0))
    with pytest.raises(ValueError):
        G.simulate(device, SHORT, [("nonsense", {}, 1.0)], 0, None)


def test_strength_zero_is_the_clean_device(device, clean_short):
    effects = [(f, _form(f), 0.0) for f in ALL]
    for effs in ([], effects):
        runs = G.simulate(device, SHORT, effs, 5, None)
        assert len(runs) == 2
        for run, sched, clean in zip(runs, SHORT, clean_short):
            assert np.array_equal(run["y_um"], clean)
            assert np.array_equal(run["v_V"], sched["v_V"])
            assert run["t_s"].shape == sched["v_V"].shape
            assert np.all(np.diff(run["t_s"]) > 0)
            # Logger: time stamps only; a reading comes after its dwell.
            assert "dwell_s" not in run
            assert run["t_s"][0] >= sched["dwell_s"][0]


def test_determinism_and_noise(device, clean_short):
    effs = [("creep", _form("creep"), 1.0), ("gain_drift", _form("gain_drift"), 0.7)]
    a = G.simulate(device, SHORT, effs, 11, 0.05)
    b = G.simulate(device, SHORT, effs, 11, 0.05)
    for ra, rb in zip(a, b):
        for key in ("t_s", "v_V", "y_um"):
            assert np.array_equal(ra[key], rb[key])
    c = G.simulate(device, SHORT, effs, 12, 0.05)
    assert not np.array_equal(_y(a), _y(c))
    # The noise does not depend on the effects, and its size is noise_um per point.
    clean_noisy = _y(G.simulate(device, SHORT, [], 11, 0.05)) - np.concatenate(clean_short)
    with_effects = _y(a) - _y(G.simulate(device, SHORT, effs, 11, None))
    assert np.allclose(clean_noisy, with_effects, atol=1e-9)
    assert 0.04 < np.std(clean_noisy) < 0.06


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output_by_a_few_percent(family, device, clean_short):
    y0 = np.concatenate(clean_short)
    swing = np.ptp(y0)
    sizes = []
    for k in range(2):
        y = _y(G.simulate(device, SHORT, [(family, _form(family, k), 1.0)], 3 + k, None))
        dev = np.abs(y - y0)
        assert np.all(np.isfinite(y))
        sizes.append(np.sqrt(np.mean(dev**2)) / swing)
        assert dev.max() < 0.08 * swing, (family, k, dev.max() / swing)
    assert max(sizes) > 0.001, (family, sizes)


@pytest.mark.parametrize("family", ALL)
def test_effect_grows_with_strength(family, device, clean_short):
    y0 = np.concatenate(clean_short)
    form = _form(family, 1)
    rms = [np.sqrt(np.mean((_y(G.simulate(device, SHORT, [(family, form, s)], 9, None)) - y0) ** 2))
           for s in (0.05, 0.5, 2.0)]
    assert 0 < rms[0] < rms[1] < rms[2], rms


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift"])
def test_drift_realisation_independent_of_strength_and_others(family, device, clean_short):
    y0 = np.concatenate(clean_short)
    form = _form(family)
    d1 = _y(G.simulate(device, SHORT, [(family, form, 1.0)], 21, None)) - y0
    d3 = _y(G.simulate(device, SHORT, [(family, form, 3.0)], 21, None)) - y0
    assert np.allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-12)
    # With another mechanism present (one acting before the sensor), the same path is added.
    other = [("reversible", _form("reversible"), 1.0)]
    y_other = _y(G.simulate(device, SHORT, other, 21, None))
    y_both = _y(G.simulate(device, SHORT, other + [(family, form, 1.0)], 21, None))
    if family == "baseline_drift":
        assert np.allclose(y_both - y_other, d1, atol=1e-12)
    else:
        assert np.allclose(y_both / y_other, (d1 + y0) / y0, rtol=1e-9)


def test_ambient_realisation_independent_of_strength_and_others(device, clean_short):
    form = _form("ambient_drift")
    _, p1 = drift.path(form, stream(21, "ambient_drift"), 20_000.0)
    _, p2 = drift.path(form, stream(21, "ambient_drift"), 20_000.0)
    assert np.array_equal(p1, p2) and p1[0] == 0.0 and np.ptp(p1) > 0
    _, p3 = drift.path(form, stream(22, "ambient_drift"), 20_000.0)
    assert not np.allclose(p1, p3)
    # Small strengths: the ambient effect scales with strength (one path, scaled), and it is the
    # same whether or not a sensor-level mechanism is also present.
    y0 = np.concatenate(clean_short)
    da = _y(G.simulate(device, SHORT, [("ambient_drift", form, 1e-4)], 21, None)) - y0
    db = _y(G.simulate(device, SHORT, [("ambient_drift", form, 2e-4)], 21, None)) - y0
    assert np.ptp(da) > 0
    assert np.allclose(db, 2.0 * da, rtol=0.02, atol=1e-9 * np.ptp(y0))
    base_only = _y(G.simulate(device, SHORT, [("baseline_drift", _form("baseline_drift"), 1.0)], 21, None))
    both = _y(G.simulate(device, SHORT, [("baseline_drift", _form("baseline_drift"), 1.0),
                                         ("ambient_drift", form, 1e-4)], 21, None))
    assert np.allclose(both - base_only, da, atol=1e-9)


def test_drift_is_different_in_each_run(device):
    form = _form("baseline_drift")
    runs = G.simulate(device, FULL[:1] + FULL[:1], [("baseline_drift", form, 1.0)], 4, None)
    assert not np.allclose(runs[0]["y_um"], runs[1]["y_um"])


def test_pairs_compose(device, clean_short):
    y0 = np.concatenate(clean_short)
    pair = [("thermal_lag", _form("thermal_lag"), 1.0), ("sensor_nonlinearity", _form("sensor_nonlinearity"), 1.0)]
    y = _y(G.simulate(device, SHORT, pair, 2, None))
    ya = _y(G.simulate(device, SHORT, pair[:1], 2, None))
    yb = _y(G.simulate(device, SHORT, pair[1:], 2, None))
    assert not np.allclose(y, ya) and not np.allclose(y, yb)
    assert np.max(np.abs(y - y0)) < 0.12 * np.ptp(y0)


def test_a_full_session_simulates_both_runs(device):
    runs = G.simulate(device, FULL, [], 0, None)
    assert [r["y_um"].size for r in runs] == [467, 360]
    # Runs last a few hours each.
    assert 1.5 * 3600 < runs[0]["t_s"][-1] < 5 * 3600
    pair = G.simulate(device, FULL, [("interaction", _form("interaction"), 1.0),
                                     ("thermal_lag", _form("thermal_lag"), 1.0)], 0, None)
    assert all(np.all(np.isfinite(r["y_um"])) for r in pair)
    assert not np.allclose(pair[0]["y_um"], runs[0]["y_um"])
