"""Tests of the blind generator gen_q (optics engineer's view of the VO2 rig)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_q import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_q.generator import _drift_path, _stream

ALL = LIBRARY + OUTSIDE


def _ident(n: int = 467) -> np.ndarray:
    """A damped oscillation on the 30-level grid's walls (the identification run's kind of input)."""
    walls = np.linspace(0.0, 6.0, 31)
    idx, lo, hi, cur = [], 0, 30, 0
    while len(idx) < n:
        idx += list(range(cur + 1, hi + 1))
        cur, hi = hi, hi - 1
        idx += list(range(cur - 1, lo - 1, -1))
        cur, lo = lo, lo + 1
        if lo >= hi:
            lo, hi = 0, 30
    return walls[np.array(idx[:n])]


def _check(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    v = [0.0]
    while len(v) < n + 1:
        if rng.random() < 0.08:
            v.append(v[-1])
        else:
            step = np.exp(rng.uniform(np.log(0.002), np.log(6.0))) * rng.choice([-1, 1])
            v.append(float(np.clip(v[-1] + step, 0.0, 6.0)))
    return np.array(v[1:]), rng.uniform(8.0, 60.0, n)


def _schedules(n1: int = 160, n2: int = 120) -> list[dict]:
    v2, d2 = _check(n2)
    return [{"v_V": _ident(n1), "dwell_s": np.full(n1, 20.0), "readings": 16},
            {"v_V": v2, "dwell_s": d2, "readings": 16}]


DEV = base.draw_device(11)
SCH = _schedules()
CLEAN = [base.clean_outputs(DEV, s["v_V"]) for s in SCH]
SWING = float(np.ptp(np.concatenate(CLEAN)))


def _form(family: str, k: int = 0) -> dict:
    return draw_form(family, np.random.default_rng(1000 + k))


def _dev(runs) -> np.ndarray:
    return np.concatenate([r["y_um"] - c for r, c in zip(runs, CLEAN)])


def test_names_and_forms_json_safe():
    assert len(LIBRARY) == 10 and len(set(LIBRARY)) == 10
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    for fam in ALL:
        for k in range(5):
            f = _form(fam, k)
            assert json.loads(json.dumps(f)) == f
    with pytest.raises(ValueError):
        draw_form("nonsense", np.random.default_rng(0))


def test_strength_zero_is_clean():
    effects = [(fam, _form(fam), 0.0) for fam in ALL]
    for eff in ([], effects):
        runs = simulate(DEV, SCH, eff, 3, None)
        for r, c, s in zip(runs, CLEAN, SCH):
            assert np.array_equal(r["y_um"], c)
            assert np.array_equal(r["v_V"], s["v_V"])


def test_determinism_and_noise_independent_of_effects():
    eff = [("creep", _form("creep"), 1.0), ("baseline_drift", _form("baseline_drift"), 1.0)]
    a = simulate(DEV, SCH, eff, 5, 0.05)
    b = simulate(DEV, SCH, eff, 5, 0.05)
    for ra, rb in zip(a, b):
        for key in ("t_s", "y_um", "dwell_s"):
            assert np.array_equal(ra[key], rb[key])
    # the noise is the same whatever the effects, and has the asked rms
    quiet = simulate(DEV, SCH, eff, 5, None)
    clean_noisy = simulate(DEV, SCH, [], 5, 0.05)
    n1 = np.concatenate([x["y_um"] - q["y_um"] for x, q in zip(a, quiet)])
    n0 = np.concatenate([x["y_um"] - c for x, c in zip(clean_noisy, CLEAN)])
    assert np.allclose(n1, n0, atol=1e-9)
    assert 0.04 < np.std(n0) < 0.06
    # another seed: another realisation
    c = simulate(DEV, SCH, eff, 6, 0.05)
    assert not np.allclose(c[0]["y_um"], a[0]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(family):
    for k in range(3):
        d = _dev(simulate(DEV, SCH, [(family, _form(family, k), 1.0)], 2, None))
        assert np.max(np.abs(d)) > 1e-3 * SWING, (family, k)
        # physical magnitudes: a few percent of the swing (rms), not tens of percent
        assert np.sqrt(np.mean(d ** 2)) < 0.05 * SWING, (family, k)


@pytest.mark.parametrize("family", ["baseline_drift", "gain_drift", "joule_power", "reversible",
                                    "first_point", "creep", "mode_hop"])
def test_linear_mechanisms_scale_exactly(family):
    """Realisation independent of strength: doubling the strength doubles the deviation."""
    f = _form(family, 1)
    d1 = _dev(simulate(DEV, SCH, [(family, f, 1.0)], 4, None))
    d2 = _dev(simulate(DEV, SCH, [(family, f, 2.0)], 4, None))
    assert np.allclose(d2, 2 * d1, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("family", ["ambient_drift", "thermal_lag", "sensor_nonlinearity", "interaction",
                                    "backlash", "accommodation"])
def test_strength_monotone_and_same_realisation(family):
    f = _form(family, 2)
    ds = [_dev(simulate(DEV, SCH, [(family, f, s)], 4, None)) for s in (0.25, 0.5, 1.0)]
    rms = [float(np.sqrt(np.mean(d ** 2))) for d in ds]
    assert rms[0] < rms[1] < rms[2], rms
    # same realisation (same path, same sign): the deviations are strongly correlated
    assert np.corrcoef(ds[0], ds[2])[0, 1] > 0.8


def test_drift_path_independent_of_strength_and_other_mechanisms():
    f = _form("ambient_drift", 3)
    t = np.linspace(0.0, 9000.0, 50)
    p1 = _drift_path(f, _stream(7, 0, 5), t)
    p2 = _drift_path(f, _stream(7, 0, 5), t)
    assert np.array_equal(p1, p2)
    # other mechanisms present do not change a drift's realisation
    fa, fb = _form("ambient_drift", 4), _form("baseline_drift", 4)
    amb = _dev(simulate(DEV, SCH, [("ambient_drift", fa, 1.0)], 9, None))
    base_only = _dev(simulate(DEV, SCH, [("baseline_drift", fb, 1.0)], 9, None))
    both = _dev(simulate(DEV, SCH, [("ambient_drift", fa, 1.0), ("baseline_drift", fb, 1.0)], 9, None))
    assert np.allclose(both, amb + base_only, atol=1e-9)
    g = _form("gain_drift", 4)
    gain = _dev(simulate(DEV, SCH, [("gain_drift", g, 1.0)], 9, None))
    both = _dev(simulate(DEV, SCH, [("gain_drift", g, 1.0), ("baseline_drift", fb, 1.0)], 9, None))
    assert np.allclose(both, gain + base_only, atol=1e-9)
    # differently in every run: the two runs' paths differ
    b0 = _drift_path(fb, _stream(9, 0, 5), t)
    b1 = _drift_path(fb, _stream(9, 1, 5), t)
    assert not np.allclose(b0, b1)


def test_prefix_stability():
    eff = [(fam, _form(fam, 5), 0.7) for fam in LIBRARY]
    one = simulate(DEV, SCH[:1], eff, 12, 0.03)
    two = simulate(DEV, SCH, eff, 12, 0.03)
    three = simulate(DEV, SCH + SCH[1:], eff, 12, 0.03)
    for key in ("t_s", "y_um", "dwell_s"):
        assert np.array_equal(one[0][key], two[0][key])
        assert np.array_equal(two[0][key], three[0][key])
        assert np.array_equal(two[1][key], three[1][key])
    eff = [(fam, _form(fam, 5), 0.7) for fam in OUTSIDE]
    two = simulate(DEV, SCH, eff, 12, 0.03)
    three = simulate(DEV, SCH + SCH[:1], eff, 12, 0.03)
    for key in ("t_s", "y_um"):
        assert np.array_equal(two[1][key], three[1][key])


def test_time_stamps_and_logger():
    runs = simulate(DEV, SCH, [], 1, None)
    for r, s in zip(runs, SCH):
        assert np.all(np.diff(r["t_s"]) > 0)
        assert np.all(r["dwell_s"] >= s["dwell_s"]) and np.all(r["dwell_s"] < s["dwell_s"] + 0.5)
        assert abs(r["t_s"][0] - r["dwell_s"][0]) < 1e-12  # each run counted from its own start


# ----------------------------------------------------------------------------------------------
# physics checks
# ----------------------------------------------------------------------------------------------

def _hold_schedule(v_hold: float, n_hold: int = 30) -> list[dict]:
    v = np.concatenate([[v_hold], np.full(n_hold, v_hold)])
    return [{"v_V": v, "dwell_s": np.full(len(v), 10.0), "readings": 8}]


def test_thermal_lag_relaxes_to_steady_state():
    """A step then a long hold: the lagging film approaches its steady state.

    Lagging paths approach from below: the reading converges to the clean one.  A heater whose
    resistance rises overshoots: hysterons switched on the way stay switched (memory), so the
    excess of metallic phase remains, of the sign of more phase.
    """
    seen = set()
    for k in range(12):
        f = _form("thermal_lag", k)
        seen.add(f["kind"])
        sch = _hold_schedule(4.0)
        clean = base.clean_outputs(DEV, sch[0]["v_V"])
        y = simulate(DEV, sch, [("thermal_lag", f, 1.0)], 0, None)[0]["y_um"]
        d = y - clean
        if f["kind"] == "heater_tcr":
            assert d[-1] >= -1e-9
            assert abs(d[-1] - d[-2]) <= abs(d[1] - d[0]) + 1e-9
        else:
            assert abs(d[-1]) <= abs(d[0]) + 1e-12
            if max(f["taus_s"]) < 30.0:
                assert abs(d[-1]) < 1e-6
    assert len(seen) >= 2


def test_sensor_nonlinearity_is_monotone_and_static():
    for k in range(6):
        f = _form("sensor_nonlinearity", k)
        runs = simulate(DEV, SCH, [("sensor_nonlinearity", f, 1.0)], 0, None)
        u = np.concatenate(CLEAN)
        y = np.concatenate([r["y_um"] for r in runs])
        order = np.argsort(u, kind="stable")
        assert np.all(np.diff(y[order]) >= -1e-9)
        # a static map: independent of time, seed and the dwells
        slow = [dict(s, dwell_s=3 * s["dwell_s"]) for s in SCH]
        y2 = np.concatenate([r["y_um"] for r in simulate(DEV, slow, [("sensor_nonlinearity", f, 1.0)], 9, None)])
        assert np.allclose(y, y2, atol=1e-12)


@pytest.mark.parametrize("family", ["backlash", "first_point"])
def test_rate_independent_mechanisms(family):
    """Backlash and the first-point transient are tied to the input's path, not to time."""
    f = _form(family, 0)
    slow = [dict(s, dwell_s=2.5 * s["dwell_s"]) for s in SCH]
    a = _dev(simulate(DEV, SCH, [(family, f, 1.0)], 0, None))
    b = _dev(simulate(DEV, slow, [(family, f, 1.0)], 0, None))
    assert np.allclose(a, b, atol=1e-12)


def test_backlash_bounded_by_play():
    f = _form("backlash", 1)
    d = _dev(simulate(DEV, SCH, [("backlash", f, 1.0)], 0, None))
    width = 2.0 * 0.01 * f["width"]  # the play at strength 1, in units of the major-loop swing
    assert np.max(np.abs(d)) <= width * SWING * 1.05


def test_first_point_only_after_reversals():
    f = dict(_form("first_point", 0), linger="none")
    v = np.array([1.0, 2.0, 3.0, 3.0, 2.5, 2.0, 1.0, 1.5, 1.5, 2.0])
    sch = [{"v_V": v, "dwell_s": np.full(len(v), 20.0), "readings": 4}]
    d = simulate(DEV, sch, [("first_point", f, 1.0)], 0, None)[0]["y_um"] - base.clean_outputs(DEV, v)
    reversal = np.array([1, 0, 0, 0, 1, 0, 0, 1, 0, 0], bool)  # first step up counts: the heater came down
    assert np.all(np.abs(d[reversal]) > 0) and np.allclose(d[~reversal], 0.0)


def test_joule_power_single_valued_in_heater():
    f = _form("joule_power", 0)
    d = _dev(simulate(DEV, SCH, [("joule_power", f, 1.0)], 0, None))
    v = np.concatenate([s["v_V"] for s in SCH])
    for vv in (0.0, 6.0):
        assert np.allclose(d[v == vv], 0.0, atol=1e-12)  # the linear and Joule shapes agree at the ends
    for vv in np.unique(v):
        assert np.ptp(d[v == vv]) < 1e-9


def test_mode_hop_steps_take_discrete_values():
    f = _form("mode_hop", 0)
    d = _dev(simulate(DEV, SCH, [("mode_hop", f, 1.0)], 0, None))
    assert len(np.unique(np.round(d, 9))) <= len(f["thresholds"]) + 1


def test_all_mechanisms_together_physical():
    eff = [(fam, _form(fam, 6), 1.0) for fam in ALL]
    runs = simulate(DEV, SCH, eff, 3, 0.02)
    for r in runs:
        assert np.all(np.isfinite(r["y_um"]))
    d = _dev(runs)
    assert np.sqrt(np.mean(d ** 2)) < 0.1 * SWING
