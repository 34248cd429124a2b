"""Blind generator G (benchmarks/blind/gen_g): clean limit, determinism, streams, prefix stability."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind.gen_g import LIBRARY, OUTSIDE, draw_form, simulate
from benchmarks.blind.gen_g.film import cell_bands
from benchmarks.blind.gen_g.schedules import check_schedule, identification_schedule, session
from benchmarks.blind.gen_g.sim import SensorNL, _Dev

ALL = LIBRARY + OUTSIDE


@pytest.fixture(scope="module")
def device():
    return base.draw_device(11)


@pytest.fixture(scope="module")
def sched(device):
    return session(device, 3)


@pytest.fixture(scope="module")
def short(device):
    """A short session (the start of both example runs) for the many-simulation tests."""
    s = session(device, 3)
    return [{k: (v[:150] if k != "readings" else v) for k, v in s[0].items()},
            {k: (v[:80] if k != "readings" else v) for k, v in s[1].items()}]


@pytest.fixture(scope="module")
def clean_short(device, short):
    return simulate(device, short, [], 5, None)


def _form(family, i=0):
    return draw_form(family, np.random.default_rng(1000 + 17 * i + len(family)))


def _dev(res, ref):
    return np.concatenate([a["y_um"] - b["y_um"] for a, b in zip(res, ref)])


def test_names():
    assert LIBRARY == ("thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
                       "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift")
    assert OUTSIDE[:2] == ("backlash", "accommodation") and len(OUTSIDE) == 3
    with pytest.raises(ValueError):
        draw_form("no_such_thing", np.random.default_rng(0))


def test_example_schedules(device):
    ident = identification_schedule(device)
    chk = check_schedule(device, 1)
    assert len(ident["v_V"]) == 467 and np.all(ident["dwell_s"] == 20.0)
    walls = np.linspace(device.v_min_V, device.v_max_V, device.levels + 1)
    assert np.all(np.min(np.abs(ident["v_V"][:, None] - walls[None, :]), axis=1) < 1e-12)
    assert 340 <= len(chk["v_V"]) <= 380
    assert chk["dwell_s"].min() >= 8.0 and chk["dwell_s"].max() <= 60.0
    assert np.any(np.diff(chk["v_V"]) == 0.0)
    assert chk["v_V"].min() >= device.v_min_V and chk["v_V"].max() <= device.v_max_V


def test_forms_json_safe_and_deterministic():
    for fam in ALL:
        for i in range(6):
            a = draw_form(fam, np.random.default_rng(i))
            b = draw_form(fam, np.random.default_rng(i))
            assert json.loads(json.dumps(a)) == a
            assert a == b


def test_strength_zero_is_clean(device, sched):
    clean = [base.clean_outputs(device, s["v_V"]) for s in sched]
    for effects in ([], [(f, _form(f), 0.0) for f in ALL]):
        res = simulate(device, sched, effects, 9, None)
        for r, c, s in zip(res, clean, sched):
            assert np.array_equal(r["y_um"], c)
            assert np.array_equal(r["v_V"], s["v_V"])


def test_cell_order_matches_base(device):
    """The cell geometry used by the accommodation matches the base device (probed through its public API)."""
    L = device.levels
    up, down = cell_bands(L)
    dv = (device.v_max_V - device.v_min_V) / L
    for c in (0, 7, 29, 30, 100, 250, 464):
        e = np.zeros_like(device.density_um)
        e[c] = 1.0
        h = dataclasses.replace(device, density_um=e).hysteresis()
        a_lo, a_hi = device.v_min_V + up[c] * dv, device.v_min_V + (up[c] + 1) * dv
        assert h.move(a_lo - 1e-9) == pytest.approx(-1.0)
        assert h.move(a_hi + 1e-9) == pytest.approx(1.0)
        h.move(device.v_max_V)
        b_lo, b_hi = device.v_min_V + down[c] * dv, device.v_min_V + (down[c] + 1) * dv
        assert h.move(b_hi + 1e-9) == pytest.approx(1.0)
        assert h.move(b_lo - 1e-9) == pytest.approx(-1.0)


def test_every_mechanism_changes_the_output(device, short, clean_short):
    swing = 2 * device.phase_swing_um
    for fam in ALL:
        for i in range(2):
            res = simulate(device, short, [(fam, _form(fam, i), 1.0)], 4, None)
            d = np.max(np.abs(_dev(res, clean_short)))
            assert d > 1e-3 * swing, (fam, i, d)
            assert d < 0.12 * swing, (fam, i, d)   # stays physical: a few percent


def test_grows_with_strength_and_vanishes_continuously(device, short, clean_short):
    for fam in ALL:
        form = _form(fam, 1)
        devs = [np.max(np.abs(_dev(simulate(device, short, [(fam, form, s)], 4, None), clean_short)))
                for s in (1e-6, 0.5, 1.0, 2.0)]
        assert devs[0] < 1e-4 * devs[2], (fam, devs)
        assert devs[1] < devs[2] < devs[3], (fam, devs)


def test_determinism_and_seed(device, sched):
    eff = [("thermal_lag", _form("thermal_lag"), 1.0), ("gain_drift", _form("gain_drift"), 1.0)]
    a = simulate(device, sched, eff, 21, 0.05)
    b = simulate(device, sched, eff, 21, 0.05)
    c = simulate(device, sched, eff, 22, 0.05)
    for x, y in zip(a, b):
        for k in ("t_s", "v_V", "y_um", "dwell_s"):
            assert np.array_equal(x[k], y[k])
    assert not np.array_equal(a[1]["y_um"], c[1]["y_um"])


def test_realisations_independent_of_strength_and_company(device, short, clean_short):
    # an additive drift scales exactly with the strength: its path is drawn from the seed, then scaled
    form = _form("baseline_drift", 2)
    d1 = _dev(simulate(device, short, [("baseline_drift", form, 1.0)], 8, None), clean_short)
    d3 = _dev(simulate(device, short, [("baseline_drift", form, 3.0)], 8, None), clean_short)
    np.testing.assert_allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-9)
    # a gain drift: log of the factor scales with the strength
    gform = _form("gain_drift", 2)
    g1 = simulate(device, short, [("gain_drift", gform, 1.0)], 8, None)
    g2 = simulate(device, short, [("gain_drift", gform, 2.0)], 8, None)
    for a, b, c in zip(g1, g2, clean_short):
        np.testing.assert_allclose(np.log(b["y_um"] / c["y_um"]), 2 * np.log(a["y_um"] / c["y_um"]),
                                   rtol=1e-7, atol=1e-9)
    # ...and is the same path whatever else is present (the baseline adds last, on top)
    rev = ("reversible", _form("reversible"), 1.0)
    with_rev = simulate(device, short, [rev], 8, None)
    both = simulate(device, short, [rev, ("baseline_drift", form, 1.0)], 8, None)
    np.testing.assert_allclose(_dev(both, with_rev), d1, rtol=1e-9, atol=1e-9)
    # the ambient path too: its effect at strength s on the film is the same path, scaled
    aform = _form("ambient_drift", 1)
    a1 = simulate(device, short, [("ambient_drift", aform, 1.0)], 8, None)
    a1b = simulate(device, short, [("ambient_drift", aform, 1.0), ("first_point", _form("first_point"), 0.0)], 8, None)
    for x, y in zip(a1, a1b):
        assert np.array_equal(x["y_um"], y["y_um"])


def test_noise_independent_of_effects(device, short, clean_short):
    eff = [("creep", _form("creep"), 1.0)]
    quiet = simulate(device, short, eff, 3, None)
    noisy = simulate(device, short, eff, 3, 0.2)
    noisy_clean = simulate(device, short, [], 3, 0.2)
    for q, n, nc, c in zip(quiet, noisy, noisy_clean, clean_short):
        np.testing.assert_allclose(n["y_um"] - q["y_um"], nc["y_um"] - c["y_um"], atol=1e-12)
    z = np.concatenate([nc["y_um"] - c["y_um"] for nc, c in zip(noisy_clean, clean_short)])
    assert 0.15 < np.std(z) < 0.25


def test_prefix_stability(device, sched):
    """A session with one more run appended repeats the first runs' readings and time stamps exactly."""
    eff = [("thermal_lag", _form("thermal_lag", 3), 1.0), ("creep", _form("creep", 3), 1.0),
           ("ambient_drift", _form("ambient_drift", 3), 1.0), ("baseline_drift", _form("baseline_drift", 3), 1.0),
           ("gain_drift", _form("gain_drift", 3), 1.0), ("accommodation", _form("accommodation", 3), 1.0),
           ("backlash", _form("backlash", 3), 1.0), ("nucleation_aftereffect", _form("nucleation_aftereffect", 3), 1.0)]
    extra = check_schedule(device, 99, n=60)
    one = simulate(device, sched[:1], eff, 17, 0.05)
    two = simulate(device, sched, eff, 17, 0.05)
    three = simulate(device, list(sched) + [extra], eff, 17, 0.05)
    assert len(three) == 3
    for shorter, longer in ((one, two), (two, three)):
        for a, b in zip(shorter, longer):
            for k in ("t_s", "v_V", "y_um", "dwell_s"):
                assert np.array_equal(a[k], b[k]), k
    # the appended run is its own: not a copy of the check run's realisation
    assert not np.array_equal(three[2]["y_um"][:60], two[1]["y_um"][:60])


def test_logger(device, sched):
    res = simulate(device, sched, [], 2, None)
    for r, s in zip(res, sched):
        t, dw = r["t_s"], r["dwell_s"]
        assert np.all(np.diff(t) > 0)
        assert np.all(dw >= s["dwell_s"]) and np.all(dw < s["dwell_s"] + 2.0)
        assert abs(t[0] - dw[0]) < 2e-3                          # the run's clock starts at its first set-point
        steps = np.diff(t) - dw[1:]                              # from one reading to the next set-point
        assert np.all(steps > 0) and np.all(steps < 0.1)
        assert 2.0 * 3600 < t[-1] < 4.0 * 3600 or len(t) < 400


def test_sensor_nonlinearity_monotone(device):
    dev = _Dev(device)
    for i in range(8):
        form = _form("sensor_nonlinearity", i)
        for s in (1.0, 10.0):
            nl = SensorNL(form, s, dev)
            u = np.linspace(dev.u_lo - 10, dev.u_hi + 10, 2001)
            assert np.all(np.diff(nl(u)) > 0)


def test_a_session_simulates_both_runs(device, sched):
    clean = simulate(device, sched, [], 1, None)
    pair = simulate(device, sched, [("interaction", _form("interaction"), 1.0), ("thermal_lag", _form("thermal_lag"), 1.0)],
                    1, None)
    assert [r["y_um"].size for r in pair] == [r["y_um"].size for r in clean] == [len(s["v_V"]) for s in sched]
    assert all(np.all(np.isfinite(r["y_um"])) for r in pair)
    assert not np.allclose(pair[0]["y_um"], clean[0]["y_um"])
