"""Tests of the blind generator ``benchmarks.blind.gen_o`` (its own physics, not the diagnosis)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind.base import clean_outputs, draw_device
from benchmarks.blind.gen_o import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_o.context import context
from benchmarks.blind.gen_o.paths import DriftPath
from benchmarks.blind.gen_o.simulate import _ThermalLag

ALL = LIBRARY + OUTSIDE
LIBRARY_NAMES = {"thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
                 "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift"}


# --------------------------------------------------------------------------- schedules

def id_schedule(stride: int = 1, levels: int = 30, vmax: float = 6.0) -> dict:
    """A damped oscillation on the grid's walls (467 set-points with stride 1), 20 s dwells."""
    walls = vmax * np.arange(levels + 1) / levels
    pts, pos, lo, hi = [], 0, 1, levels
    ext = []
    while lo <= hi:
        ext += [hi, lo]
        hi, lo = hi - stride, lo + stride
    for e in ext:
        step = 1 if e > pos else -1
        while pos != e:
            pos = min(pos + stride, e) if step > 0 else max(pos - stride, e)
            pts.append(pos)
    pts += [min(pos + 1, levels), pos]
    v = walls[np.array(pts)]
    return {"v_V": v, "dwell_s": np.full(v.size, 20.0), "readings": 10}


def check_schedule(seed: int = 0, n: int = 360, vmax: float = 6.0) -> dict:
    """Random reversals, steps from mV to the whole range, dwells 8-60 s, some repeats."""
    rng = np.random.default_rng(seed)
    v, x, d = [], 0.0, 1
    for i in range(n):
        if i and rng.uniform() < 0.1:
            v.append(x)
            continue
        if rng.uniform() < 0.45:
            d = -d
        step = float(np.exp(rng.uniform(np.log(0.002), np.log(vmax))))
        x2 = x + d * step
        if not 0.0 <= x2 <= vmax:
            d = -d
            x2 = x + d * step
        x = float(np.clip(x2, 0.0, vmax))
        v.append(x)
    return {"v_V": np.array(v), "dwell_s": np.exp(rng.uniform(np.log(8), np.log(60), n)), "readings": 10}


FULL = [id_schedule(), check_schedule(1)]
SHORT = [id_schedule(stride=3), check_schedule(2, n=90)]


def forms_for(family, seeds=(0,)):
    return [draw_form(family, np.random.default_rng(1000 + s)) for s in seeds]


def clean_session(device, schedules):
    return [clean_outputs(device, s["v_V"]) for s in schedules]


def deviation(out, clean):
    return np.concatenate([o["y_um"] - c for o, c in zip(out, clean)])


@pytest.fixture(scope="module")
def device():
    return draw_device(4)


# --------------------------------------------------------------------------- interface

def test_names():
    assert set(LIBRARY) == LIBRARY_NAMES and len(LIBRARY) == 10
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    assert OUTSIDE[2] not in LIBRARY_NAMES


@pytest.mark.parametrize("family", ALL)
def test_forms_json_safe_deterministic_and_varied(family):
    a = draw_form(family, np.random.default_rng(5))
    b = draw_form(family, np.random.default_rng(5))
    assert json.loads(json.dumps(a)) == a == b
    many = {json.dumps(draw_form(family, np.random.default_rng(s)), sort_keys=True) for s in range(40)}
    assert len(many) == 40
    # broad families: the categorical choices (kernel, shape, law...) vary too
    cats = set()
    for s in range(40):
        f = draw_form(family, np.random.default_rng(s))
        cats.add(json.dumps({k: v for k, v in f.items() if isinstance(v, str)}, sort_keys=True)
                 if "components" not in f else json.dumps(sorted(c["kind"] for c in f["components"])))
    assert len(cats) >= 2


def test_unknown_family_and_bad_strength(device):
    with pytest.raises(ValueError):
        draw_form("nonsense", np.random.default_rng(0))
    with pytest.raises(ValueError):
        simulate(device, SHORT, [("nonsense", {}, 1.0)], 0, None)
    with pytest.raises(ValueError):
        simulate(device, SHORT, [("creep", forms_for("creep")[0], -1.0)], 0, None)


# --------------------------------------------------------------------------- honesty rules

def test_strength_zero_is_the_clean_device(device):
    clean = clean_session(device, FULL)
    effects = [(f, forms_for(f)[0], 0.0) for f in ALL]
    for eff in ([], effects):
        out = simulate(device, FULL, eff, seed=3, noise_um=None)
        assert len(out) == 2
        for o, c, s in zip(out, clean, FULL):
            assert np.array_equal(o["y_um"], c)
            assert np.array_equal(o["v_V"], s["v_V"])
            assert np.all(np.diff(o["t_s"]) > 0) and o["t_s"][0] > 0
            assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 1.0)


def test_determinism_and_seed(device):
    effects = [(f, forms_for(f, (7,))[0], 1.0) for f in ALL]
    a = simulate(device, SHORT, effects, seed=11, noise_um=0.03)
    b = simulate(device, SHORT, effects, seed=11, noise_um=0.03)
    c = simulate(device, SHORT, effects, seed=12, noise_um=0.03)
    for x, y, z in zip(a, b, c):
        for key in ("t_s", "y_um", "dwell_s", "v_V"):
            assert np.array_equal(x[key], y[key])
        assert not np.array_equal(x["y_um"], z["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output_physically_and_monotonically(device, family):
    ctx = context(device)
    clean = clean_session(device, SHORT)
    for form in forms_for(family, (0, 1, 2)):
        rms = []
        for s in (1e-7, 1.0, 2.5):
            dev = deviation(simulate(device, SHORT, [(family, form, s)], seed=2, noise_um=None), clean)
            rms.append(np.sqrt(np.mean(dev ** 2)))
            if s == 1.0:
                assert np.max(np.abs(dev)) < 0.08 * ctx.swing_um  # a few percent at most
        assert rms[0] < 1e-4 * ctx.swing_um  # continuous at 0
        assert rms[1] > 5e-4 * ctx.swing_um  # visible at strength 1
        assert rms[0] < rms[1] < rms[2]  # grows with the strength


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift"])
def test_drift_realisation_scales_with_strength(device, family):
    clean = clean_session(device, SHORT)
    form = forms_for(family)[0]
    d1 = deviation(simulate(device, SHORT, [(family, form, 1.0)], seed=5, noise_um=None), clean)
    d3 = deviation(simulate(device, SHORT, [(family, form, 3.0)], seed=5, noise_um=None), clean)
    np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("family", ["baseline_drift", "ambient_drift", "gain_drift"])
def test_drift_realisation_independent_of_other_mechanisms(device, family):
    """An additive last stage on top: the drift's own contribution is unchanged by its presence."""
    clean = clean_session(device, SHORT)
    form = forms_for(family)[0]
    fp = ("first_point", forms_for("first_point")[0], 1.0)
    base = ("baseline_drift", forms_for("baseline_drift", (3,))[0], 1.0)
    other = fp if family != "first_point" else base
    alone = simulate(device, SHORT, [(family, form, 1.0)], seed=9, noise_um=None)
    with_other = simulate(device, SHORT, [other, (family, form, 1.0)], seed=9, noise_um=None)
    other_only = simulate(device, SHORT, [other], seed=9, noise_um=None)
    for a, w, o, c in zip(alone, with_other, other_only, clean):
        np.testing.assert_allclose(w["y_um"] - o["y_um"], a["y_um"] - c, atol=1e-9)
    # and the unit path itself depends on (seed, run, mechanism) only
    p1 = DriftPath(form, 9, 1, family, -700.0, 9000.0)
    p2 = DriftPath(form, 9, 1, family, -700.0, 9000.0)
    p3 = DriftPath(form, 9, 0, family, -700.0, 9000.0)
    tt = np.linspace(0, 8000, 50)
    assert np.array_equal(p1(tt), p2(tt)) and not np.array_equal(p1(tt), p3(tt))
    assert np.max(np.abs(p1(tt))) < 6.0


def test_noise_independent_of_effects(device):
    effects = [("creep", forms_for("creep")[0], 1.0), ("backlash", forms_for("backlash")[0], 1.0)]
    n0 = [o["y_um"] for o in simulate(device, SHORT, [], seed=4, noise_um=0.05)]
    c0 = [o["y_um"] for o in simulate(device, SHORT, [], seed=4, noise_um=None)]
    n1 = [o["y_um"] for o in simulate(device, SHORT, effects, seed=4, noise_um=0.05)]
    c1 = [o["y_um"] for o in simulate(device, SHORT, effects, seed=4, noise_um=None)]
    for a, b, c, d in zip(n0, c0, n1, c1):
        np.testing.assert_allclose(a - b, c - d, atol=1e-12)
        assert 0.035 < np.std(a - b) < 0.065
    # the two runs' noises are not the same draw
    assert not np.allclose((n0[0] - c0[0])[:50], (n0[1] - c0[1])[:50])


def test_prefix_stability(device):
    effects = [(f, forms_for(f, (3,))[0], 1.0) for f in ALL]
    one = simulate(device, SHORT[:1], effects, seed=21, noise_um=0.02)
    two = simulate(device, SHORT, effects, seed=21, noise_um=0.02)
    three = simulate(device, SHORT + [check_schedule(9, n=40)], effects, seed=21, noise_um=0.02)
    for key in ("t_s", "y_um", "dwell_s"):
        assert np.array_equal(one[0][key], two[0][key])
        assert np.array_equal(two[0][key], three[0][key])
        assert np.array_equal(two[1][key], three[1][key])


# --------------------------------------------------------------------------- physics guards

def test_thermal_lag_signs():
    for mode, sign in (("lag", -1.0), ("lead", 1.0)):
        form = {"kernel": "double", "mode": mode, "taus_s": [5.0, 120.0],
                "weights": [0.5 * -sign, 0.5 * -sign], "fraction_per_strength": 0.01}
        lag = _ThermalLag(form, 1.0)
        lag.step(0.0, 0.0)
        lag.step(100.0, 36.0)  # a step up after a long time at 0 V
        p = lag.power(np.array([0.0, 1.0, 10.0, 60.0, 1e5]))
        assert np.all(sign * (p[:-1] - 36.0) > 0)  # short of (lag) / beyond (lead) steady state
        assert np.all(sign * np.diff(p) <= 0)  # relaxing monotonically towards it
        assert abs(p[-1] - 36.0) < 1e-9


def _hold_schedule(dwell):
    v = np.array([3.0, 4.2, 4.2, 4.2, 4.2, 4.2, 4.2, 2.0, 2.0, 2.0, 2.0, 4.5, 3.8, 4.6])
    return [{"v_V": v, "dwell_s": np.full(v.size, dwell), "readings": 5}]


def test_creep_relaxes_towards_the_clean_device(device):
    form = {"kernel": "exponentials", "taus_s": [60.0], "weights": [1.0], "law": "linear",
            "up_factor": 1.0, "down_factor": 1.0, "direction": "forward", "source": "deflection",
            "fraction_per_strength": 0.03}
    sch = _hold_schedule(30.0)
    clean = clean_outputs(device, sch[0]["v_V"])
    dev = simulate(device, sch, [("creep", form, 1.0)], 0, None)[0]["y_um"] - clean
    held = np.abs(dev[1:7])
    assert np.all(np.diff(held) < 0) and held[-1] < 0.1 * held[0]
    # forward creep: the reading lags behind the change
    assert np.sign(dev[1]) == -np.sign(clean[1] - clean[0])


@pytest.mark.parametrize("family", ["backlash", "first_point", "sensor_nonlinearity", "reversible",
                                    "interaction", "joule_power", "accommodation"])
def test_rate_independent_mechanisms_ignore_the_dwell(device, family):
    form = forms_for(family, (1,))[0]
    a = simulate(device, _hold_schedule(10.0), [(family, form, 1.0)], 0, None)[0]["y_um"]
    b = simulate(device, _hold_schedule(55.0), [(family, form, 1.0)], 0, None)[0]["y_um"]
    np.testing.assert_allclose(a, b, atol=1e-12)


def test_first_point_only_after_reversals(device):
    form = {"size_law": "none", "convention": "along", "swing_fraction": 0.02,
            "up_factor": 1.0, "down_factor": 0.5, "linger": 0.0}
    sch = _hold_schedule(20.0)
    v = sch[0]["v_V"]
    dev = simulate(device, sch, [("first_point", form, 1.0)], 0, None)[0]["y_um"] - clean_outputs(device, v)
    dv = np.diff(np.concatenate([[0.0], v]))
    # runs start "coming down": the first rise is a reversal; then 4.2 -> 2.0 (down), 2.0 -> 4.5 (up),
    # 4.5 -> 3.8 (down), 3.8 -> 4.6 (up)
    expected = np.zeros(v.size, dtype=bool)
    expected[[0, 7, 11, 12, 13]] = True
    assert np.array_equal(np.abs(dev) > 1e-12, expected)
    assert np.all(np.sign(dev[expected]) == np.sign(dv[expected]))


def test_backlash_lags_after_reversal(device):
    form = {"kind": "play", "asymmetry": 0.0, "half_width_swing_fraction": 0.01}
    sch = _hold_schedule(20.0)
    v = sch[0]["v_V"]
    clean = clean_outputs(device, v)
    dev = simulate(device, sch, [("backlash", form, 1.0)], 0, None)[0]["y_um"] - clean
    r = 0.01 * context(device).swing_um
    assert np.all(np.abs(dev) <= r + 1e-12)
    # after a large move the mount trails behind the beam by the whole play
    for i in (1, 7):
        du = clean[i] - clean[i - 1]
        assert abs(du) > 2 * r
        assert np.isclose(dev[i], -np.sign(du) * r)


def test_accommodation_grows_with_cycles(device):
    form = {"law": "linear", "prior_cycles": 0.0,
            "patterns": [{"pattern": "fatigue", "sign": -1.0, "weight": 1.0}], "swing_fraction": 0.02}
    sch = [id_schedule(stride=2)]
    clean = clean_outputs(device, sch[0]["v_V"])
    dev = simulate(device, sch, [("accommodation", form, 1.0)], 0, None)[0]["y_um"] - clean
    n = dev.size
    assert np.max(np.abs(dev[: n // 6])) < np.max(np.abs(dev[-n // 3:]))


def test_fringes_follow_the_deflection_not_the_time(device):
    form = draw_form("spillover_fringes", np.random.default_rng(3))
    form.update(drift_rad_per_h=0.0, power_phase_rad=0.0, envelope="none", shape="sine")
    sch = _hold_schedule(20.0)
    clean = clean_outputs(device, sch[0]["v_V"])
    dev = simulate(device, sch, [("spillover_fringes", form, 1.0)], 0, None)[0]["y_um"] - clean
    A = form["swing_fraction"] * context(device).swing_um
    expect = A * np.sin(2 * np.pi * (clean - context(device).u_lo) / form["period_um"] + form["phase_rad"])
    np.testing.assert_allclose(dev, expect, atol=1e-9)


def test_a_full_session_simulates_both_runs(device):
    effects = [(f, forms_for(f, (2,))[0], 1.0) for f in LIBRARY]
    out = simulate(device, FULL, effects, seed=1, noise_um=None)
    assert [o["y_um"].size for o in out] == [467, 360]
