"""Blind generator C: strength 0 is the clean device, determinism, every mechanism acts,
realisations independent of the strength and of the other mechanisms, speed, logger convention."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_c as G
from benchmarks.blind.gen_c import paths

ALL = G.LIBRARY + G.OUTSIDE


def _damped(levels: int = 30, v_max: float = 6.0, limit: int | None = None) -> dict:
    """A damped oscillation over the grid's walls (467 set-points for 30 levels), 20 s dwells."""
    walls = np.linspace(0.0, v_max, levels + 1)
    seq, i = [0.0], 0
    for d in range(levels, 0, -1):
        for s0 in range(levels - d + 1):
            seq.append(walls[s0 + d] if i % 2 == 0 else walls[s0])
            i += 1
    seq.append(walls[levels // 2])
    v = np.array(seq[:limit] if limit else seq)
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 10}


def _check(n: int = 360, seed: int = 0, v_max: float = 6.0) -> dict:
    """Random reversals, steps from mV to the whole range, 8-60 s dwells, some repeats."""
    rng = np.random.default_rng(seed)
    v, x, d = [0.0], 0.0, 1
    while len(v) < n:
        if rng.random() < 0.1:
            v.append(x)
            continue
        if rng.random() < 0.5:
            d = -d
        x = float(np.clip(x + d * np.exp(rng.uniform(np.log(0.002), np.log(v_max))), 0.0, v_max))
        v.append(x)
    v = np.array(v)
    return {"v_V": v, "dwell_s": rng.uniform(8.0, 60.0, v.size), "readings": 10}


@pytest.fixture(scope="module")
def device():
    return base.draw_device(3)


@pytest.fixture(scope="module")
def short():
    """Short schedules for the many per-mechanism simulations."""
    return [_damped(limit=120), _check(80, seed=1)]


@pytest.fixture(scope="module")
def clean_short(device, short):
    return [base.clean_outputs(device, s["v_V"]) for s in short]


def _y(out) -> np.ndarray:
    return np.concatenate([o["y_um"] for o in out])


def _form(family: str, k: int = 0) -> dict:
    return G.draw_form(family, np.random.default_rng(1000 + 17 * k + len(family)))


def test_names_and_forms_are_json_safe():
    assert len(G.LIBRARY) == 10 and len(set(G.LIBRARY)) == 10
    assert set(G.OUTSIDE) >= {"backlash", "accommodation"} and len(G.OUTSIDE) == 3
    for fam in ALL:
        for k in range(6):
            form = _form(fam, k)
            assert json.loads(json.dumps(form)) == form
            assert _form(fam, k) == form  # draw_form is a function of the rng only
    with pytest.raises(ValueError):
        G.draw_form("no_such_thing", np.random.default_rng(0))


def test_strength_zero_is_the_clean_device(device):
    sched = [_damped(), _check(360, seed=2)]
    effects = [(fam, _form(fam), 0.0) for fam in ALL]
    for effs in ([], effects):
        out = G.simulate(device, sched, effs, 5, None)
        for o, s in zip(out, sched):
            np.testing.assert_array_equal(o["y_um"], base.clean_outputs(device, s["v_V"]))
            np.testing.assert_array_equal(o["v_V"], s["v_V"])


def test_logger_convention(device, short):
    out = G.simulate(device, short, [], 0, None)
    for o, s in zip(out, short):
        assert set(o) == {"t_s", "v_V", "y_um"}  # this lab's logger writes no dwell_s
        burst = s["readings"] * G.READ_PERIOD_S
        expect = np.cumsum(G.OVERHEAD_S + s["dwell_s"] + burst) - 0.5 * burst
        np.testing.assert_allclose(o["t_s"], expect, rtol=0, atol=1e-9)


def test_determinism_and_noise(device, short, clean_short):
    effs = [("creep", _form("creep"), 1.0), ("baseline_drift", _form("baseline_drift"), 0.7)]
    a = G.simulate(device, short, effs, 11, 0.05)
    b = G.simulate(device, short, effs, 11, 0.05)
    for x, y in zip(a, b):
        for k in x:
            np.testing.assert_array_equal(x[k], y[k])
    c = G.simulate(device, short, effs, 12, 0.05)
    assert not np.array_equal(_y(a), _y(c))
    # the noise does not depend on the effects
    noise_clean = _y(G.simulate(device, short, [], 11, 0.05)) - np.concatenate(clean_short)
    noise_eff = _y(a) - _y(G.simulate(device, short, effs, 11, None))
    np.testing.assert_allclose(noise_eff, noise_clean, atol=1e-9)
    assert 0.03 < np.std(noise_clean) < 0.07


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output_and_grows_with_strength(family, device, short, clean_short):
    clean = np.concatenate(clean_short)
    swing = np.ptp(clean)
    for k in range(2):
        form = _form(family, k)
        strengths = (1.0, 0.5, 2.0) if k == 0 else (1.0,)
        gaps, peak = [], 0.0
        for s in strengths:
            y = _y(G.simulate(device, short, [(family, form, s)], 4, None))
            assert np.all(np.isfinite(y))
            gaps.append(float(np.sqrt(np.mean((y - clean) ** 2))))
            peak = max(peak, float(np.max(np.abs(y - clean)))) if s == 1.0 else peak
        assert gaps[0] > 1e-4 * swing, (family, form)  # strength 1 changes the output
        assert peak < 0.15 * swing, (family, form)  # ... by a few percent, not more
        if k == 0:
            assert gaps[1] < gaps[0] < gaps[2], (family, gaps)  # and grows with the strength


@pytest.mark.parametrize("family,key", [("baseline_drift", "amplitude_frac"), ("gain_drift", "amplitude_rel"),
                                        ("ambient_drift", "amplitude_K")])
def test_drift_realisation_is_independent_of_strength(family, key, device, short):
    """Strength s with amplitude a == strength 2 s with amplitude a / 2: the path is drawn, then scaled."""
    for k in range(3):
        form = _form(family, k)
        half = dict(form, **{key: form[key] / 2.0})
        y1 = _y(G.simulate(device, short, [(family, form, 0.8)], 9, None))
        y2 = _y(G.simulate(device, short, [(family, half, 1.6)], 9, None))
        np.testing.assert_allclose(y1, y2, rtol=0, atol=1e-9)


def test_realisations_independent_of_other_mechanisms(device, short, clean_short):
    clean = np.concatenate(clean_short)
    rev = ("reversible", _form("reversible"), 1.0)
    base_d = ("baseline_drift", _form("baseline_drift", 1), 1.0)
    gain = ("gain_drift", _form("gain_drift", 1), 1.0)
    amb = ("ambient_drift", _form("ambient_drift", 1), 1.0)
    sim = lambda effs: _y(G.simulate(device, short, effs, 21, None))  # noqa: E731
    y_rev, y_base, y_gain, y_amb = sim([rev]), sim([base_d]), sim([gain]), sim([amb])
    # the baseline path is the same with or without another mechanism
    np.testing.assert_allclose(sim([rev, base_d]) - y_rev, y_base - clean, atol=1e-9)
    # the gain path too
    np.testing.assert_allclose(sim([amb, gain]) / y_amb, y_gain / clean, rtol=1e-12)
    # the ambient path does not change when a drift of the sensor is present
    np.testing.assert_allclose(sim([amb, base_d]) - y_base, y_amb - clean, atol=1e-9)


def test_drift_paths_start_at_zero_and_differ_between_runs():
    for k in range(8):
        form = _form("baseline_drift", k)
        g0, p0 = paths.drift_path(form, paths.stream(3, "baseline_drift", 0), 3 * 3600.0)
        g1, p1 = paths.drift_path(form, paths.stream(3, "baseline_drift", 1), 3 * 3600.0)
        assert p0[0] == 0.0 and p1[0] == 0.0
        assert 0.2 < np.max(np.abs(p0)) < 5.0
        assert not np.allclose(p0, p1)


def test_a_full_session_simulates_both_runs(device):
    sched = [_damped(), _check(360, seed=3)]
    clean = G.simulate(device, sched, [], 0, None)
    effs = [(fam, _form(fam), 1.0) for fam in G.LIBRARY]
    out = G.simulate(device, sched, effs, 0, None)
    assert [o["y_um"].size for o in out] == [467, 360] == [o["y_um"].size for o in clean]
    assert all(np.all(np.isfinite(o["y_um"])) for o in out)
