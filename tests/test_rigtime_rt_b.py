"""The rt_b rig-time simulator: blind thermal dynamics on top of benchmarks.blind.base."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from benchmarks.blind import base
from benchmarks.rigtime import rt_b
from benchmarks.rigtime.rt_b import sim


def _schedule(n, rng, dwell=2.0, readings=4, reading_s=0.5, measured_frac=0.8):
    return {
        "v_V": rng.uniform(0.0, 6.0, n),
        "dwell_s": np.full(n, float(dwell)) if np.isscalar(dwell) else np.asarray(dwell, float),
        "readings": np.full(n, readings, dtype=int),
        "measured": rng.uniform(size=n) < measured_frac,
        "reading_s": reading_s,
    }


def _forms(k, seed=0, extras=False):
    rng = np.random.default_rng(seed)
    return [rt_b.draw_form(float(np.exp(rng.uniform(np.log(0.5), np.log(20.0)))), rng, extras)
            for _ in range(k)]


def test_film_phase_equals_base_hysteresis():
    for seed in range(3):
        dev = base.draw_device(seed)
        h, f = dev.hysteresis(), sim._Film(dev)
        rng = np.random.default_rng(seed)
        xs = np.concatenate([rng.uniform(-0.5, 6.5, 150), np.round(rng.uniform(0, 6, 50) / 0.2) * 0.2])
        for x in xs:
            f.move(float(f.coordinates(np.array([x]))[0]))
            assert abs(h.move(x) - f.phase()) < 1e-10


def test_draw_form_shape_and_tau():
    rng = np.random.default_rng(5)
    for _ in range(200):
        tau_s = float(np.exp(rng.uniform(np.log(0.5), np.log(20.0))))
        form = rt_b.draw_form(tau_s, rng)
        assert json.loads(json.dumps(form)) == form
        assert rt_b.characteristic_tau_s(form) == pytest.approx(tau_s)
        tau, a, b = (np.array(form[k]) for k in ("tau_modes_s", "film_weights", "beam_weights"))
        assert a.sum() == pytest.approx(1.0) and b.sum() == pytest.approx(1.0)
        assert np.all(b >= 0) and a.min() >= -0.05
        assert sim._monotone(a, tau)  # no overshoot: temperatures stay between ambient and full scale
        slow = tau > tau_s
        assert np.all(a[slow] < 0.2) and np.all(tau <= 5.0 * tau_s + 1e-9)


def test_instant_form_equals_clean_device():
    rng = np.random.default_rng(1)
    for seed in range(3):
        dev = base.draw_device(seed)
        sch = _schedule(120, rng, dwell=rng.uniform(0, 3, 120))
        out = rt_b.simulate(dev, sch, rt_b.instant_form(), 0, None)
        clean = base.clean_outputs(dev, sch["v_V"])
        m = sch["measured"]
        assert np.all(np.isnan(out["y_um"][~m]))
        np.testing.assert_allclose(out["y_um"][m], clean[m], rtol=0, atol=1e-10)
        step = sch["dwell_s"] + np.where(m, 4 * 0.5, 0.0)
        np.testing.assert_allclose(out["t_s"], np.cumsum(step))


def test_long_dwells_converge_to_clean_device():
    rng = np.random.default_rng(2)
    dev = base.draw_device(4)
    for form in _forms(4, seed=3):
        sch = _schedule(40, rng)
        sch["dwell_s"] = np.full(40, rt_b.settling_time_s(form, 1e-9))
        out = rt_b.simulate(dev, sch, form, 0, None)
        clean = base.clean_outputs(dev, sch["v_V"])
        m = sch["measured"]
        assert np.max(np.abs(out["y_um"][m] - clean[m])) <= 1e-6 * dev.phase_swing_um


def test_settling_time_is_tight_and_sufficient():
    for form in _forms(3, seed=4):
        tau, a = np.array(form["tau_modes_s"]), np.array(form["film_weights"])
        tol = 1e-3
        ts = rt_b.settling_time_s(form, tol)
        worst = 0.0
        for xa, xb in [(1.0, 0.0), (0.0, 1.0), (0.5, 0.0), (1.0, 0.6), (0.2, 0.9)]:
            u = xb**2

            def rhs(t, m, u=u):
                return sim._warp(form, u, m.sum()) * (a * u - m) / tau

            sol = solve_ivp(rhs, (0.0, ts), a * xa**2, method="LSODA", rtol=1e-10, atol=1e-14,
                            dense_output=True)
            for t in np.linspace(ts, 2 * ts, 5):  # stays within the band after ts
                assert abs(np.sqrt(max(sol.sol(min(t, ts)).sum(), 0.0)) - xb) <= tol * abs(xb - xa)
            worst = max(worst, abs(np.sqrt(sol.y[:, -1].sum()) - xb) / abs(xb - xa))
        assert worst > 0.5 * tol  # not wildly conservative
        assert rt_b.settling_time_s(form, 1e-9) > ts > rt_b.settling_time_s(form, 1e-1)


def test_determinism_and_noise_independent_of_form():
    rng = np.random.default_rng(6)
    dev = base.draw_device(2)
    sch = _schedule(60, rng, dwell=1.0)
    f1, f2 = _forms(2, seed=7, extras=True)
    a = rt_b.simulate(dev, sch, f1, 11, 0.05)
    b = rt_b.simulate(dev, sch, f1, 11, 0.05)
    for k in ("t_s", "v_V", "y_um"):
        np.testing.assert_array_equal(a[k], b[k])
    n1 = a["y_um"] - rt_b.simulate(dev, sch, f1, 11, None)["y_um"]
    n2 = rt_b.simulate(dev, sch, f2, 11, 0.05)["y_um"] - rt_b.simulate(dev, sch, f2, 11, None)["y_um"]
    m = sch["measured"]
    np.testing.assert_allclose(n1[m], n2[m], atol=1e-12)
    c = rt_b.simulate(dev, sch, f1, 12, 0.05)
    assert not np.allclose(a["y_um"][m], c["y_um"][m])


def test_short_dwell_differs_from_long():
    rng = np.random.default_rng(8)
    dev = base.draw_device(1)
    for form in _forms(3, seed=9):
        sch = _schedule(30, rng, measured_frac=1.0)
        short = rt_b.simulate(dev, sch, form, 0, None)["y_um"]
        sch["dwell_s"] = np.full(30, rt_b.settling_time_s(form, 1e-6))
        long = rt_b.simulate(dev, sch, form, 0, None)["y_um"]
        assert np.max(np.abs(short - long)) > 0.05 * dev.phase_swing_um


def test_noise_rms_when_film_is_still():
    dev = base.draw_device(3)
    n, K = 2500, 4
    sch = {"v_V": np.full(n, 4.0), "dwell_s": np.full(n, 0.0), "readings": np.full(n, K),
           "measured": np.ones(n, bool), "reading_s": 0.5}
    form = _forms(1, seed=10)[0]
    sch["dwell_s"][0] = rt_b.settling_time_s(form, 1e-9)
    clean = rt_b.simulate(dev, sch, form, 3, None)["y_um"]
    noisy = rt_b.simulate(dev, sch, form, 3, 0.2)["y_um"]
    rms = np.std(noisy - clean)
    assert rms == pytest.approx(0.2 / np.sqrt(K), rel=0.05)


def test_extras_are_small():
    rng = np.random.default_rng(12)
    dev = base.draw_device(5)
    for form in _forms(4, seed=13, extras=True):
        sch = _schedule(40, rng, dwell=3.0, measured_frac=1.0)
        with_ = rt_b.simulate(dev, sch, form, 0, None)["y_um"]
        without = rt_b.simulate(dev, sch, dict(form, extra=None), 0, None)["y_um"]
        d = np.max(np.abs(with_ - without))
        assert 0 < d <= 1e-3 * dev.phase_swing_um


def test_speed():
    rng = np.random.default_rng(14)
    dev = base.draw_device(6)
    sch = _schedule(500, rng, dwell=2.0, readings=4, measured_frac=1.0)
    form = _forms(1, seed=15, extras=True)[0]
    rt_b.simulate(dev, sch, form, 0, None)
    t = time.perf_counter()
    rt_b.simulate(dev, sch, form, 0, None)
    # a guard against a pathological slow-down (e.g. stepping the linear dynamics point by point), not a
    # benchmark: typically 0.2-0.5 s, and a loaded 2-core CI machine must not fail it
    assert time.perf_counter() - t < 5.0
