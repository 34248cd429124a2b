"""Tests of the blind generator ``benchmarks.blind.gen_p`` (honesty rules of SPEC.md and physics checks)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_p import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_p import paths as gp_paths
from benchmarks.blind.gen_p import session as gp_session

ALL = LIBRARY + OUTSIDE
DRIFTS = ("baseline_drift", "ambient_drift", "gain_drift")


# --------------------------------------------------------------------------- schedules
def id_schedule(levels: int = 30, n: int | None = None, vmax: float = 6.0, K: int = 20) -> dict:
    """A damped oscillation on the walls of a ``levels`` grid (20 s dwells)."""
    walls = np.linspace(0.0, vmax, levels + 1)
    seq: list[int] = []
    for m in range(levels, 0, -1):
        lo, hi = 0, m
        while lo <= hi:
            seq.append(hi)
            if lo != hi:
                seq.append(lo)
            lo, hi = lo + 1, hi - 1
    n = n or levels * (levels + 1) // 2 + 2
    seq = seq[: n - 1] + [levels // 2]
    v = walls[np.array(seq)]
    return {"v_V": v, "dwell_s": np.full(len(v), 20.0), "readings": K}


def check_schedule(seed: int = 0, n: int = 360, vmax: float = 6.0, K: int = 20) -> dict:
    """Random reversals, steps from millivolts to the whole range, 8-60 s dwells, some repeats."""
    rng = np.random.default_rng(seed)
    v = [float(rng.uniform(0.0, vmax))]
    d = 1.0
    while len(v) < n:
        r = rng.random()
        if r < 0.08:
            v.append(v[-1])
            continue
        if r < 0.35:
            d = -d
        step = float(np.exp(rng.uniform(np.log(0.002), np.log(vmax))))
        nv = v[-1] + d * step
        if nv < 0.0 or nv > vmax:
            d = -d
            nv = v[-1] + d * step
        v.append(float(np.clip(nv, 0.0, vmax)))
    return {"v_V": np.array(v), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": K}


def hold_schedule(v_hold: float, n_hold: int = 12, dwell: float = 20.0) -> dict:
    """Rest, one step to ``v_hold``, then the same set-point repeated (a relaxation record)."""
    v = np.array([0.0, 0.0] + [v_hold] * n_hold)
    return {"v_V": v, "dwell_s": np.full(len(v), dwell), "readings": 10}


def cycles_schedule(v_mid: float, n_cycles: int = 30, vmax: float = 6.0) -> dict:
    v = np.tile([0.0, v_mid, vmax, v_mid], n_cycles)
    return {"v_V": v, "dwell_s": np.full(len(v), 15.0), "readings": 10}


@pytest.fixture(scope="module")
def device():
    return base.draw_device(4)


@pytest.fixture(scope="module")
def small():
    """A short session (same structure as the real one) for the many-call tests."""
    return [id_schedule(levels=12), check_schedule(1, n=90)]


@pytest.fixture(scope="module")
def tiny():
    """An even shorter session, for the tests that run every mechanism at once."""
    return [id_schedule(levels=8), check_schedule(3, n=40)]


@pytest.fixture(scope="module")
def full():
    return [id_schedule(), check_schedule(2)]


def forms(family: str, n: int, seed: int = 0) -> list[dict]:
    rng = np.random.default_rng([seed, ALL.index(family)])
    return [draw_form(family, rng) for _ in range(n)]


def clean(device, schedules):
    return [base.clean_outputs(device, s["v_V"]) for s in schedules]


def ys(out) -> np.ndarray:
    return np.concatenate([o["y_um"] for o in out])


def swing(device) -> float:
    return gp_session._Ctx(device).swing


def steepest_v(device) -> float:
    """The set-point where the clean ascending branch is steepest (inside the transition)."""
    vs = np.linspace(0.0, device.v_max_V, 121)
    y = base.clean_outputs(device, vs) - device.thermal_um_per_V * vs
    return float(vs[np.argmax(np.diff(y)) + 1])


# --------------------------------------------------------------------------- API and forms
def test_names():
    assert set(LIBRARY) == {"thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
                            "sensor_nonlinearity", "reversible", "interaction", "first_point",
                            "gain_drift"}
    assert len(LIBRARY) == 10
    assert {"backlash", "accommodation"} <= set(OUTSIDE) and len(OUTSIDE) == 3
    assert not set(LIBRARY) & set(OUTSIDE)


@pytest.mark.parametrize("family", ALL)
def test_forms_json_safe_and_reproducible(family):
    a = forms(family, 6, seed=3)
    b = forms(family, 6, seed=3)
    assert a == b
    for f in a:
        assert json.loads(json.dumps(f)) == f
    assert len({json.dumps(f, sort_keys=True) for f in a}) > 1   # a family, not one law


def test_bad_inputs(device, small):
    with pytest.raises(ValueError):
        draw_form("nonsense", np.random.default_rng(0))
    with pytest.raises(ValueError):
        simulate(device, small, [("creep", forms("creep", 1)[0], -1.0)], 0, None)


# --------------------------------------------------------------------------- honesty rules
def test_strength_zero_is_clean_device(device, tiny):
    small = tiny
    ref = clean(device, small)
    out = simulate(device, small, [], 1, None)
    for o, c in zip(out, ref):
        assert np.array_equal(o["y_um"], c)
    for family in ALL:
        for f in forms(family, 2):
            out0 = simulate(device, small, [(family, f, 0.0)], 1, None)
            for o, c in zip(out0, ref):
                assert np.array_equal(o["y_um"], c), family
    # all at once at zero, with noise: the same as the clean device with the same noise
    zero = [(fam, forms(fam, 1)[0], 0.0) for fam in ALL]
    a = simulate(device, small, zero, 5, 0.05)
    b = simulate(device, small, [], 5, 0.05)
    assert np.array_equal(ys(a), ys(b))


def test_strength_zero_is_clean_on_full_session(device, full):
    zero = [(fam, forms(fam, 1, seed=9)[0], 0.0) for fam in ALL]
    for o, c in zip(simulate(device, full, zero, 2, None), clean(device, full)):
        assert np.array_equal(o["y_um"], c)


def test_determinism(device, tiny):
    eff = [(fam, forms(fam, 1, seed=1)[0], 1.0) for fam in ALL]
    a = simulate(device, tiny, eff, 11, 0.02)
    b = simulate(device, tiny, eff, 11, 0.02)
    for x, y in zip(a, b):
        for key in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[key], y[key])
    c = simulate(device, tiny, eff, 12, 0.02)
    assert not np.array_equal(ys(a), ys(c))


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_output_physically(family, device, small):
    ref = np.concatenate(clean(device, small))
    sw = swing(device)
    for f in forms(family, 3, seed=5):
        dev = ys(simulate(device, small, [(family, f, 1.0)], 3, None)) - ref
        assert np.max(np.abs(dev)) > 2e-4 * sw, (family, f)
        assert np.max(np.abs(dev)) < 0.12 * sw, (family, f)        # a few percent, not a new device
        assert np.sqrt(np.mean(dev ** 2)) < 0.04 * sw, (family, f)


@pytest.mark.parametrize("family", ALL)
def test_effect_grows_with_strength(family, device, tiny):
    small = tiny
    ref = np.concatenate(clean(device, small))
    for f in forms(family, 1, seed=8):
        r = [np.sqrt(np.mean((ys(simulate(device, small, [(family, f, s)], 4, None)) - ref) ** 2))
             for s in (1e-9, 0.3, 1.0, 3.0)]
        assert r[0] < 1e-6 and r[0] < r[1] < r[2] < r[3], (family, r)


@pytest.mark.parametrize("family", DRIFTS)
def test_drift_realisation_independent_of_strength(family, device, small):
    ref = np.concatenate(clean(device, small))
    f = forms(family, 1, seed=2)[0]
    d1 = ys(simulate(device, small, [(family, f, 1.0)], 7, None)) - ref
    d2 = ys(simulate(device, small, [(family, f, 2.0)], 7, None)) - ref
    if family == "baseline_drift":
        np.testing.assert_allclose(d2, 2.0 * d1, rtol=1e-9, atol=1e-12)
    elif family == "gain_drift":
        ok = np.abs(ref) > 1.0
        g1, g2 = np.log1p(d1[ok] / ref[ok]), np.log1p(d2[ok] / ref[ok])
        np.testing.assert_allclose(g2, 2.0 * g1, rtol=1e-7, atol=1e-12)
    else:
        # the same path, scaled: the realised temperature offsets are exactly proportional
        t_end = float(simulate(device, small, [], 7, None)[0]["t_s"][-1]) + 100.0
        _, p1 = gp_paths.realise(f, 7, 0, family, t_end)
        _, p2 = gp_paths.realise(f, 7, 0, family, t_end)
        assert np.array_equal(p1, p2)
        moved = np.abs(d1) > 1e-9
        assert np.all(np.sign(d1[moved]) == np.sign(d2[moved]))
    # another seed: another realisation; another run: another realisation
    d3 = ys(simulate(device, small, [(family, f, 1.0)], 8, None)) - ref
    assert not np.allclose(d1, d3)


def test_drift_realisation_independent_of_other_mechanisms(device, small):
    ref = np.concatenate(clean(device, small))
    fb, fa, fg, fj, fc = (forms(x, 1, seed=4)[0] for x in
                          ("baseline_drift", "ambient_drift", "gain_drift", "joule_power", "creep"))
    # baseline: additive at the end of the chain, whatever comes before it
    only = ys(simulate(device, small, [("baseline_drift", fb, 1.0)], 3, None)) - ref
    with_j = ys(simulate(device, small, [("joule_power", fj, 1.0), ("baseline_drift", fb, 1.0)], 3, None))
    j = ys(simulate(device, small, [("joule_power", fj, 1.0)], 3, None))
    np.testing.assert_allclose(with_j - j, only, atol=1e-10)
    # gain: the same sensitivity path with or without creep upstream
    g_only = ys(simulate(device, small, [("gain_drift", fg, 1.0)], 3, None)) / ref
    both = ys(simulate(device, small, [("creep", fc, 1.0), ("gain_drift", fg, 1.0)], 3, None))
    c = ys(simulate(device, small, [("creep", fc, 1.0)], 3, None))
    ok = np.abs(ref) > 1.0
    np.testing.assert_allclose((both / c)[ok & (np.abs(c) > 1.0)], g_only[ok & (np.abs(c) > 1.0)], rtol=1e-9)
    # ambient: the same temperature path whatever sensor mechanism follows
    a_only = ys(simulate(device, small, [("ambient_drift", fa, 1.0)], 3, None)) - ref
    ab = ys(simulate(device, small, [("ambient_drift", fa, 1.0), ("baseline_drift", fb, 1.0)], 3, None))
    b = ys(simulate(device, small, [("baseline_drift", fb, 1.0)], 3, None))
    np.testing.assert_allclose(ab - b, a_only, atol=1e-10)


def test_drifts_differ_between_runs(device):
    sched = [check_schedule(3, n=80)] * 2       # the same schedule twice
    for family in DRIFTS:
        f = forms(family, 1, seed=6)[0]
        out = simulate(device, sched, [(family, f, 1.0)], 3, None)
        assert not np.allclose(out[0]["y_um"], out[1]["y_um"]), family


def test_prefix_stability(device, tiny):
    eff = [(fam, forms(fam, 1, seed=7)[0], 1.0) for fam in ALL]
    extra = check_schedule(9, n=30)
    one = simulate(device, tiny[:1], eff, 21, 0.03)
    two = simulate(device, tiny, eff, 21, 0.03)
    three = simulate(device, tiny + [extra], eff, 21, 0.03)
    for key in ("t_s", "v_V", "y_um", "dwell_s"):
        assert np.array_equal(one[0][key], two[0][key])
        for r in range(2):
            assert np.array_equal(two[r][key], three[r][key])


def test_noise_independent_of_effects(device, tiny):
    small = tiny
    noise = 0.05
    sets = [[], [(fam, forms(fam, 1, seed=8)[0], 1.0) for fam in LIBRARY],
            [("backlash", forms("backlash", 1)[0], 2.0)]]
    diffs = []
    for eff in sets:
        a = ys(simulate(device, small, eff, 4, noise))
        b = ys(simulate(device, small, eff, 4, None))
        diffs.append(a - b)
    for d in diffs[1:]:
        np.testing.assert_allclose(d, diffs[0], atol=1e-12)
    assert 0.8 * noise < np.std(diffs[0]) < 1.2 * noise


def test_logger_time_stamps(device, small):
    eff = [("thermal_lag", forms("thermal_lag", 1)[0], 1.0)]
    out = simulate(device, small, eff, 6, None)
    ref = simulate(device, small, [], 6, None)
    for o, r, s in zip(out, ref, small):
        assert np.array_equal(o["t_s"], r["t_s"])                  # timing does not depend on effects
        assert np.all(np.diff(o["t_s"]) > 0.0)
        extra = o["dwell_s"] - s["dwell_s"]
        assert np.all(extra > 0.0) and np.all(extra < 1.5)          # latency + half a burst
        steps = np.diff(o["t_s"])
        assert np.all(steps >= s["dwell_s"][1:])
        assert abs(o["t_s"][0] - o["dwell_s"][0]) < 1e-12


# --------------------------------------------------------------------------- physics
def test_thermal_lag_relaxes_towards_steady_state(device):
    v = steepest_v(device)
    sched = [hold_schedule(v, n_hold=16, dwell=20.0)]
    ref = clean(device, sched)[0]
    for f in forms("thermal_lag", 5, seed=1):
        dev = simulate(device, sched, [("thermal_lag", f, 1.0)], 1, None)[0]["y_um"] - ref
        hold = np.abs(dev[2:])
        assert hold[0] > 1e-3
        assert np.all(np.diff(hold) <= 1e-9)                        # heating up, monotonically
        assert hold[-1] < 0.7 * hold[0]


def test_creep_relaxes_and_vanishes_at_rest(device):
    v = steepest_v(device) + 0.5
    sched = [hold_schedule(v, n_hold=40, dwell=600.0)]
    ref = clean(device, sched)[0]
    for f in forms("creep", 5, seed=2):
        dev = simulate(device, sched, [("creep", f, 1.0)], 1, None)[0]["y_um"] - ref
        hold = np.abs(dev[2:])
        assert np.all(np.diff(hold) <= 1e-9)
        assert hold[-1] < 0.2 * hold[0] + 1e-6 or max(f["taus_s"]) > 3000.0
        assert np.all(np.abs(dev[:2]) < 1e-12)                      # nothing before the first change


def test_ambient_drift_leaves_the_insulating_film_alone(device):
    sched = [{"v_V": np.zeros(60), "dwell_s": np.full(60, 60.0), "readings": 10},
             {"v_V": np.full(60, device.v_max_V), "dwell_s": np.full(60, 60.0), "readings": 10}]
    ref = clean(device, sched)
    for f in forms("ambient_drift", 8, seed=3):
        if f["bimorph"]:
            continue
        out = simulate(device, sched, [("ambient_drift", f, 1.0)], 2, None)
        np.testing.assert_allclose(out[0]["y_um"], ref[0], atol=1e-9)   # far below the transition
        # fully metallic: only the last grains near the top may come back
        np.testing.assert_allclose(out[1]["y_um"], ref[1], atol=2e-3 * swing(device))


def test_ambient_drift_temperatures_are_plausible(device, small):
    for f in forms("ambient_drift", 10, seed=4):
        _, p = gp_paths.realise(f, 1, 0, "ambient_drift", 4 * 3600.0)
        assert np.max(np.abs(f["amp_K"] * p)) < 3.0                 # K at strength 1


def test_joule_power_keeps_the_ends(device):
    vs = np.linspace(0.0, device.v_max_V, 25)
    sched = [{"v_V": np.concatenate([vs, vs[::-1]]), "dwell_s": np.full(50, 20.0), "readings": 5}]
    ref = clean(device, sched)[0]
    for f in forms("joule_power", 5, seed=5):
        y = simulate(device, sched, [("joule_power", f, 1.0)], 0, None)[0]["y_um"]
        dev = y - ref
        assert abs(dev[0]) < 1e-9 and abs(dev[24]) < 1e-9 and abs(dev[-1]) < 1e-9
        assert np.max(np.abs(dev)) > 1e-3
        # single-valued in v: the same deviation on the way up and on the way down
        np.testing.assert_allclose(dev[:25], dev[25:][::-1], atol=1e-9)


def test_sensor_nonlinearity_is_smooth_and_monotone(device, small):
    ref = np.concatenate(clean(device, small))
    order = np.argsort(ref, kind="stable")
    for f in forms("sensor_nonlinearity", 8, seed=6):
        y = ys(simulate(device, small, [("sensor_nonlinearity", f, 3.0)], 0, None))
        assert np.all(np.diff(y[order]) >= -1e-12)
        # a function of the deflection only: equal deflections, equal readings
        _, inv = np.unique(np.round(ref, 12), return_inverse=True)
        for k in np.unique(inv)[:50]:
            assert np.ptp(y[inv == k]) < 1e-9


def test_reversible_is_single_valued(device, small):
    ref = np.concatenate(clean(device, small))
    v = np.concatenate([s["v_V"] for s in small])
    for f in forms("reversible", 8, seed=7):
        dev = ys(simulate(device, small, [("reversible", f, 1.0)], 0, None)) - ref
        for vv in np.unique(v):
            assert np.ptp(dev[v == vv]) < 1e-9


def test_interaction_is_self_consistent_and_avalanche_free(device):
    ctx = gp_session._Ctx(device)
    vs = np.linspace(0.0, device.v_max_V, 241)
    for f, s in zip(forms("interaction", 4, seed=8), (1.0, 5.0, 1.0, 5.0)):
        if True:
            film = gp_session._Film(ctx, (f, s), None, 0.0)
            phases = []
            for x in np.concatenate([vs, vs[::-1]]):
                ph = film.move(float(x))
                assert abs(film.z_last - x - film.alpha * (ph - film.pref)) < 1e-8
                phases.append(ph)
            phases = np.array(phases)
            up, down = phases[:241], phases[241:]
            assert np.all(np.diff(up) >= -1e-9) and np.all(np.diff(down) <= 1e-9)
            assert np.max(np.abs(np.diff(up))) < 0.25 * 2.0 * device.phase_swing_um   # no avalanche
            assert film.gain < 0.7


def test_first_point_only_after_reversals(device, small):
    ref = clean(device, small)
    for f in forms("first_point", 8, seed=9):
        out = simulate(device, small, [("first_point", f, 1.0)], 0, None)
        for o, r, s in zip(out, ref, small):
            dev = o["y_um"] - r
            v = np.concatenate([[0.0], s["v_V"]])
            dirs = np.sign(np.diff(v))
            allowed = np.zeros(len(dev), bool)
            last = 0.0
            for i, d in enumerate(dirs):
                if d != 0.0:
                    if last != 0.0 and d != last:
                        allowed[i: i + 1 + f["n_linger"]] = True
                    last = d
            assert np.all(np.abs(dev[~allowed]) < 1e-12)
            assert np.any(np.abs(dev[allowed]) > 1e-6)


def test_backlash_holds_the_reading_inside_the_play(device):
    # up to v_max, down to 0.5 V, then tiny steps further down: the thermal term (c < 0) turns
    # the beam back up by far less than the play, and the reading stays put
    v = np.concatenate([[device.v_max_V, 0.5], 0.5 - 0.001 * np.arange(1, 11)])
    sched = [{"v_V": v, "dwell_s": np.full(len(v), 20.0), "readings": 5}]
    for f in forms("backlash", 10, seed=10):
        if f["kind"] != "single":
            continue
        y = simulate(device, sched, [("backlash", f, 3.0)], 0, None)[0]["y_um"]
        assert np.ptp(y[1:]) < 1e-12
        assert np.ptp(clean(device, sched)[0][1:]) > 1e-3


def test_accommodation_grows_with_cycles_and_carries_over(device):
    v_mid = steepest_v(device)
    sched = [cycles_schedule(v_mid, 25), cycles_schedule(v_mid, 10)]
    ref = clean(device, sched)
    for f in forms("accommodation", 6, seed=11):
        out = simulate(device, sched, [("accommodation", f, 1.0)], 0, None)
        tops = [np.abs(o["y_um"] - r)[1::4] for o, r in zip(out, ref)]    # same input, same memory
        assert np.all(np.diff(tops[0]) >= -1e-9)
        assert tops[0][-1] > tops[0][0]
        assert tops[1][0] >= tops[0][-1] - 1e-9                             # fatigue does not heal


def test_heater_aging_is_cumulative(device):
    v = steepest_v(device)
    sched = [{"v_V": np.tile([device.v_max_V, v], 60), "dwell_s": np.full(120, 60.0), "readings": 5},
             {"v_V": np.tile([device.v_max_V, v], 10), "dwell_s": np.full(20, 60.0), "readings": 5}]
    ref = clean(device, sched)
    for f in forms("heater_aging", 6, seed=12):
        f = dict(f, law="em", m=1.3)
        out = simulate(device, sched, [("heater_aging", f, 1.0)], 0, None)
        dev = [np.abs(o["y_um"] - r)[1::2] for o, r in zip(out, ref)]
        assert np.all(np.diff(dev[0]) >= -1e-9) and dev[0][-1] > dev[0][0]
        assert dev[1][0] >= dev[0][-1] - 1e-9


def test_full_session_all_mechanisms(device, full):
    eff = [(fam, forms(fam, 1, seed=13)[0], 1.0) for fam in ALL]
    out = simulate(device, full, eff, 1, 0.02)
    assert [len(o["y_um"]) for o in out] == [len(s["v_V"]) for s in full]
    for o in out:
        assert np.all(np.isfinite(o["y_um"]))
        assert 2.0 * 3600 < o["t_s"][-1] < 6.0 * 3600                      # a few hours
    dev = ys(out) - np.concatenate(clean(device, full))
    assert np.max(np.abs(dev)) < 0.25 * swing(device)
