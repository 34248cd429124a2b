"""Tests of the rt_d rig-time simulator (distributed cantilever, patchy film, PSD window)."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.rigtime import rt_d
from benchmarks.rigtime.rt_d.form import defining_mode
from benchmarks.rigtime.rt_d.preisach import Memory, everett
from benchmarks.rigtime.rt_d.thermal import Network


def _schedule(v, dwell, readings=4, measured=None, reading_s=0.1):
    n = len(v)
    return {
        "v_V": np.asarray(v, dtype=float),
        "dwell_s": np.broadcast_to(np.asarray(dwell, dtype=float), (n,)).copy(),
        "readings": np.broadcast_to(np.asarray(readings), (n,)).astype(int),
        "measured": np.ones(n, bool) if measured is None else np.asarray(measured, bool),
        "reading_s": reading_s,
    }


def _path(rng, n):
    v = rng.uniform(0.0, 6.0, n)
    v[rng.uniform(size=n) < 0.1] = 0.0
    v[rng.uniform(size=n) < 0.1] = 6.0
    return v


@pytest.fixture(scope="module")
def device():
    return base.draw_device(7)


@pytest.fixture(scope="module")
def forms():
    rng = np.random.default_rng(2024)
    return [rt_d.draw_form(tau, rng, extras=False) for tau in (0.5, 3.0, 20.0)]


def test_everett_matches_base_hysteresis(device):
    ev = everett(device)
    rng = np.random.default_rng(1)
    h, m = device.hysteresis(), Memory(ev)
    xs = np.concatenate([rng.uniform(-0.5, 6.5, 150), np.cumsum(rng.normal(0, 0.2, 150)) % 6.0,
                         [6.0, 0.0, 3.0, 3.0, 2.9, 3.1, 6.5, -1.0]])
    ph = m.trace(xs)
    ref = np.array([h.move(x) for x in xs])
    np.testing.assert_allclose(ph, ref, rtol=0, atol=1e-10)
    for x in rng.uniform(0, 6, 20):
        assert abs(m.peek(x) - h.peek(x)) < 1e-10


def test_instant_form_equals_clean_device(device):
    rng = np.random.default_rng(3)
    v = _path(rng, 120)
    meas = rng.uniform(size=v.size) < 0.7
    out = rt_d.simulate(device, _schedule(v, 0.0, 3, meas), rt_d.instant_form(), 0, None)
    clean = base.clean_outputs(device, v)
    np.testing.assert_allclose(out["y_um"][meas], clean[meas], rtol=0, atol=1e-12)
    assert np.all(np.isnan(out["y_um"][~meas]))
    np.testing.assert_array_equal(out["v_V"], v)


def test_forms_are_json_safe_and_calibrated(forms):
    for form in forms:
        again = json.loads(json.dumps(form))
        assert again == form
        tau, _, _ = defining_mode(Network(form))
        assert tau == pytest.approx(form["tau_s"], rel=1e-9)
        st3 = rt_d.settling_time_s(form, 1e-3)
        st9 = rt_d.settling_time_s(form, 1e-9)
        assert form["tau_s"] < st3 < st9 < 400 * form["tau_s"]
    rng = np.random.default_rng(5)
    assert rt_d.draw_form(2.0, np.random.default_rng(9)) == rt_d.draw_form(2.0, np.random.default_rng(9))
    assert rt_d.draw_form(2.0, rng, extras=False)["extra"] is None
    assert rt_d.draw_form(2.0, rng, extras=True)["extra"]["kind"] in ("drift", "creep")


def test_long_dwells_converge_to_clean_device(device, forms):
    rng = np.random.default_rng(11)
    v = _path(rng, 40)
    meas = rng.uniform(size=v.size) < 0.85
    clean = base.clean_outputs(device, v)
    for form in forms:
        dwell = rt_d.settling_time_s(form, 1e-9)
        out = rt_d.simulate(device, _schedule(v, dwell, rng.integers(1, 6, v.size), meas), form, 0, None)
        err = np.max(np.abs(out["y_um"][meas] - clean[meas]))
        assert err <= 1e-6 * device.phase_swing_um, (form["tau_s"], err)


def test_short_dwell_differs_from_long(device, forms):
    rng = np.random.default_rng(12)
    v = _path(rng, 40)
    for form in forms:
        short = rt_d.simulate(device, _schedule(v, 0.3 * form["tau_s"]), form, 0, None)["y_um"]
        long = rt_d.simulate(device, _schedule(v, rt_d.settling_time_s(form, 1e-6)), form, 0, None)["y_um"]
        assert np.max(np.abs(short - long)) > 0.05 * device.phase_swing_um


def test_deterministic(device):
    rng = np.random.default_rng(13)
    form = rt_d.draw_form(1.5, rng, extras=True)
    v = _path(rng, 50)
    sch = _schedule(v, 1.0, 3)
    a = rt_d.simulate(device, sch, form, 42, 0.05)
    b = rt_d.simulate(device, sch, json.loads(json.dumps(form)), 42, 0.05)
    for k in ("t_s", "v_V", "y_um"):
        np.testing.assert_array_equal(a[k], b[k])
    c = rt_d.simulate(device, sch, form, 43, 0.05)
    assert not np.array_equal(a["y_um"], c["y_um"])
    # times: each point's last reading, from the run's start
    np.testing.assert_allclose(a["t_s"], np.cumsum(np.full(v.size, 1.0 + 3 * 0.1)))


def test_noise_rms_when_still(device, forms):
    noise, K, n = 0.3, 4, 1500
    v = np.full(n, 3.7)
    clean = base.clean_outputs(device, v)
    res = []
    for form in forms[:2]:
        sch = _schedule(v, rt_d.settling_time_s(form, 1e-9), K)
        y = rt_d.simulate(device, sch, form, 77, noise)["y_um"]
        res.append(y - clean)
    rms = np.sqrt(np.mean(res[0] ** 2))
    assert rms == pytest.approx(noise / np.sqrt(K), rel=0.06)
    assert abs(np.mean(res[0])) < 4 * noise / np.sqrt(K * n)
    # the noise does not depend on the form
    np.testing.assert_allclose(res[0], res[1], rtol=0, atol=1e-9)


def test_extras_are_small(device):
    rng = np.random.default_rng(14)
    v = _path(rng, 40)
    for _ in range(4):
        form = rt_d.draw_form(1.0, rng, extras=True)
        bare = dict(form, extra=None)
        sch = _schedule(v, 1.5)
        a = rt_d.simulate(device, sch, form, 0, None)["y_um"]
        b = rt_d.simulate(device, sch, bare, 0, None)["y_um"]
        assert np.max(np.abs(a - b)) <= 1e-3 * device.phase_swing_um + 1e-12


def test_no_overshoot_from_steady_state(device, forms):
    from benchmarks.rigtime.rt_d.thermal import Segment
    for form in forms:
        net = Network(form)
        for u1, u2 in ((0.0, 6.0), (6.0, 0.5), (2.0, 4.5), (4.5, 2.0)):
            C = net.capacities(device.kelvin_per_V2 * u2 * u2 * net.gamma, np.full(net.M, 0.5))
            seg = Segment(net, C, u1 * u1 * net.gamma, u1, u2)
            t = np.geomspace(1e-6, 300.0, 400) * form["tau_s"]
            theta = u2 * u2 * net.gain + seg.dev(t)
            x = np.sqrt(np.maximum(theta, 0.0) / net.gain)
            lo, hi = min(u1, u2), max(u1, u2)
            assert np.all(x >= lo - 1e-9) and np.all(x <= hi + 1e-9)


def test_speed_500_points(device, forms):
    rng = np.random.default_rng(15)
    v = rng.uniform(0.0, 6.0, 500)
    form = max(forms, key=lambda f: f["patches"])
    sch = _schedule(v, form["tau_s"], 4)
    t0 = time.process_time()
    out = rt_d.simulate(device, sch, form, 0, None)
    # a guard against a pathological slow-down, in this process's CPU time (a loaded machine must not fail it)
    assert time.process_time() - t0 < 2.0  # typically 0.15-0.45 s
    assert np.all(np.isfinite(out["y_um"]))
