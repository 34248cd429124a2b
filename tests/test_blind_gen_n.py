"""Tests of the blind generator gen_n (benchmarks/blind/gen_n): a MEMS packaging engineer's rig."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_n import LIBRARY, OUTSIDE, draw_form, simulate

ALL = LIBRARY + OUTSIDE


def _ident(levels: int = 30, n: int = 467, readings: int = 10) -> dict:
    """A damped-oscillation-like identification run on the walls of ``levels`` levels (first-order reversals)."""
    w = np.linspace(0.0, 6.0, levels + 1)
    seq: list[float] = []
    for a in range(1, levels + 1):
        seq.append(w[a])
        seq.extend(w[a - 1::-1][:a])
    seq = seq[: n - 1] + [3.1]
    return {"v_V": np.array(seq), "dwell_s": np.full(len(seq), 20.0), "readings": readings}


def _check(n: int = 360, seed: int = 0, readings: int = 10) -> dict:
    """A check run: random reversals, steps from millivolts to the range, dwells 8-60 s, some repeats."""
    rng = np.random.default_rng(seed)
    v, d, out = 0.0, 1.0, []
    for _ in range(n):
        if out and rng.uniform() < 0.08:
            out.append(out[-1])
            continue
        if rng.uniform() < 0.4:
            d = -d
        step = float(np.exp(rng.uniform(np.log(1e-3), np.log(6.0))))
        if not 0.0 <= v + d * step <= 6.0:
            d = -d
        v = float(np.clip(v + d * step, 0.0, 6.0))
        out.append(v)
    return {"v_V": np.array(out), "dwell_s": rng.uniform(8.0, 60.0, n), "readings": readings}


DEVICE = base.draw_device(7)
SHORT = [_ident(levels=12), _check(100, seed=3)]          # a short session for most tests
FULL = [_ident(), _check()]                          # the session of SPEC.md
CLEAN_SHORT = [base.clean_outputs(DEVICE, s["v_V"]) for s in SHORT]
SWING = float(np.ptp(base.clean_outputs(DEVICE, FULL[0]["v_V"])))


def _form(family: str, k: int = 0) -> dict:
    return draw_form(family, np.random.default_rng(1000 + 17 * k + ALL.index(family)))


def _y(out) -> np.ndarray:
    return np.concatenate([r["y_um"] for r in out])


def _effect(effects, schedules=SHORT, seed=11) -> np.ndarray:
    out = simulate(DEVICE, schedules, effects, seed, None)
    clean = CLEAN_SHORT if schedules is SHORT else [base.clean_outputs(DEVICE, s["v_V"]) for s in schedules]
    return _y(out) - np.concatenate(clean)


def test_names():
    assert len(LIBRARY) == 10 and len(set(ALL)) == 13
    assert OUTSIDE[:2] == ("backlash", "accommodation")
    with pytest.raises(KeyError):
        draw_form("no_such_thing", np.random.default_rng(0))


@pytest.mark.parametrize("family", ALL)
def test_forms_json_safe_and_deterministic(family):
    for k in range(5):
        a, b = _form(family, k), _form(family, k)
        assert json.loads(json.dumps(a)) == a == b


def test_strength_zero_is_the_clean_device():
    effects = [(f, _form(f), 0.0) for f in ALL]
    for effs in ([], effects):
        out = simulate(DEVICE, SHORT, effs, 5, None)
        for r, s, c in zip(out, SHORT, CLEAN_SHORT):
            assert np.array_equal(r["y_um"], c)
            assert np.array_equal(r["v_V"], s["v_V"])


def test_logger_time_stamps():
    out = simulate(DEVICE, SHORT, [], 5, None)
    for r, s in zip(out, SHORT):
        assert set(r) == {"t_s", "v_V", "y_um", "dwell_s"}
        assert np.all(np.diff(r["t_s"]) > 0) and r["t_s"][0] > 0
        lag = r["dwell_s"] - s["dwell_s"]
        assert np.all((lag > 0) & (lag < 0.6))            # latency + half the burst
        change = r["t_s"] - r["dwell_s"]
        assert change[0] == 0.0 and np.all(np.diff(change) >= s["dwell_s"][:-1])


def test_determinism():
    effects = [("thermal_lag", _form("thermal_lag"), 1.0), ("gain_drift", _form("gain_drift"), 2.0)]
    a = simulate(DEVICE, SHORT, effects, 3, 0.05)
    b = simulate(DEVICE, SHORT, effects, 3, 0.05)
    for ra, rb in zip(a, b):
        for key in ra:
            assert np.array_equal(ra[key], rb[key])
    c = simulate(DEVICE, SHORT, effects, 4, 0.05)
    assert not np.array_equal(a[0]["y_um"], c[0]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(family):
    for k in range(4):
        e = _effect([(family, _form(family, k), 1.0)])
        assert np.max(np.abs(e)) > 1e-3 * SWING, (family, k)


@pytest.mark.parametrize("family", ALL)
def test_strength_grows_the_effect(family):
    form = _form(family, 1)
    sizes = [float(np.sqrt(np.mean(_effect([(family, form, s)]) ** 2))) for s in (0.25, 0.5, 1.0, 2.0)]
    assert all(b > a for a, b in zip(sizes, sizes[1:])), (family, sizes)
    small = _effect([(family, form, 1e-6)])
    assert np.max(np.abs(small)) < 1e-3 * SWING  # continuous at zero


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift", "creep", "reversible", "first_point"])
def test_realisation_independent_of_strength(family):
    """The drawn realisation is scaled by the strength, not redrawn: these effects are linear in it."""
    form = _form(family, 2)
    e1, e3 = _effect([(family, form, 1.0)]), _effect([(family, form, 3.0)])
    np.testing.assert_allclose(e3, 3.0 * e1, rtol=1e-7, atol=1e-9 * SWING)


def test_ambient_and_aging_paths_independent_of_strength():
    from benchmarks.blind.gen_n.scales import device_ref
    from benchmarks.blind.gen_n.thermal import Ambient

    form = _form("ambient_drift", 3)
    a1 = Ambient(form, 1.0, 9, 1, 8000.0, 0.7).values
    a2 = Ambient(form, 2.5, 9, 1, 8000.0, 0.7).values
    np.testing.assert_allclose(a2, 2.5 * a1, rtol=1e-12)
    longer = Ambient(form, 1.0, 9, 1, 20000.0, 0.7).values  # and of how long the run is
    np.testing.assert_array_equal(longer[: a1.size], a1)
    assert device_ref(DEVICE) is device_ref(DEVICE)


def test_realisations_independent_of_other_mechanisms():
    elec = dict(_form("baseline_drift", 4), stage="electronics")
    amb, rev, gain = _form("ambient_drift", 1), _form("reversible", 1), _form("gain_drift", 1)
    # an additive read-out offset is the same whatever else is present
    e_b = _effect([("baseline_drift", elec, 1.0)])
    e_br = _effect([("baseline_drift", elec, 1.0), ("reversible", rev, 1.0)])
    e_r = _effect([("reversible", rev, 1.0)])
    np.testing.assert_allclose(e_br - e_r, e_b, atol=1e-9)
    # the ambient path too (the temperature stage does not see the read-out)
    e_a = _effect([("ambient_drift", amb, 1.0)])
    e_ab = _effect([("ambient_drift", amb, 1.0), ("baseline_drift", elec, 1.0)])
    np.testing.assert_allclose(e_ab - e_b, e_a, atol=1e-9)
    # a gain path multiplies whatever deflection there is by the same factor
    y_r = _y(simulate(DEVICE, SHORT, [("reversible", rev, 1.0)], 11, None))
    y_rg = _y(simulate(DEVICE, SHORT, [("reversible", rev, 1.0), ("gain_drift", gain, 1.0)], 11, None))
    y_g = _y(simulate(DEVICE, SHORT, [("gain_drift", gain, 1.0)], 11, None))
    clean = np.concatenate(CLEAN_SHORT)
    ok = (np.abs(y_r) > 1.0) & (np.abs(clean) > 1.0)
    np.testing.assert_allclose((y_rg / y_r)[ok], (y_g / clean)[ok], rtol=1e-9)
    # and the order in which effects are listed does not matter
    e_ba = _effect([("baseline_drift", elec, 1.0), ("ambient_drift", amb, 1.0)])
    np.testing.assert_array_equal(e_ab, e_ba)


def test_noise_independent_of_effects():
    effects = [("creep", _form("creep"), 1.0), ("baseline_drift", _form("baseline_drift"), 1.0)]
    n0 = _y(simulate(DEVICE, SHORT, [], 21, 0.1)) - _y(simulate(DEVICE, SHORT, [], 21, None))
    n1 = _y(simulate(DEVICE, SHORT, effects, 21, 0.1)) - _y(simulate(DEVICE, SHORT, effects, 21, None))
    np.testing.assert_allclose(n0, n1, atol=1e-12)
    assert 0.07 < np.std(n0) < 0.13
    n2 = _y(simulate(DEVICE, SHORT, [], 21, 0.2)) - _y(simulate(DEVICE, SHORT, [], 21, None))
    np.testing.assert_allclose(n2, 2.0 * n0, rtol=1e-12, atol=1e-12)


def test_prefix_stability():
    effects = [(f, _form(f), 1.0) for f in ("thermal_lag", "creep", "baseline_drift", "ambient_drift",
                                               "gain_drift", "accommodation", "conductance_aging")]
    third = _check(60, seed=9)
    for effs in ([], effects[:2], effects[2:4], effects[4:]):
        two = simulate(DEVICE, SHORT, effs, 8, 0.03)
        three = simulate(DEVICE, SHORT + [third], effs, 8, 0.03)
        assert len(three) == 3
        for a, b in zip(two, three[:2]):
            for key in a:
                assert np.array_equal(a[key], b[key]), key


def test_pairs_compose():
    pairs = [("thermal_lag", "interaction"), ("creep", "sensor_nonlinearity"), ("ambient_drift", "joule_power"),
             ("first_point", "gain_drift"), ("reversible", "thermal_lag")]
    for a, b in pairs:
        e = _effect([(a, _form(a), 1.0), (b, _form(b), 1.0)])
        assert np.all(np.isfinite(e)) and np.max(np.abs(e)) > 1e-3 * SWING
        assert np.max(np.abs(e)) < 0.2 * SWING


def test_calibration_on_the_full_session():
    """Strength 1: clearly visible, and no mechanism moves the deflection by more than a few per cent."""
    clean = np.concatenate([base.clean_outputs(DEVICE, s["v_V"]) for s in FULL])
    for family in ALL:
        e = _y(simulate(DEVICE, FULL, [(family, _form(family), 1.0)], 2, None)) - clean
        assert 0.002 * SWING < np.max(np.abs(e)) < 0.10 * SWING, (family, np.max(np.abs(e)) / SWING)


def test_a_noise_free_session_simulates_both_runs():
    heavy = [("thermal_lag", _form("thermal_lag"), 1.0), ("interaction", _form("interaction"), 1.0)]
    outs = [simulate(DEVICE, FULL, effects, 1, None)
            for effects in ([], heavy, [("ambient_drift", _form("ambient_drift"), 1.0)])]
    for out in outs:
        assert [o["y_um"].size for o in out] == [len(s["v_V"]) for s in FULL]
        assert all(np.all(np.isfinite(o["y_um"])) for o in out)
    for out in outs[1:]:
        assert not np.allclose(out[0]["y_um"], outs[0][0]["y_um"])
