"""Tests of the blind rig-time simulator rt_c (benchmarks/rigtime/rt_c)."""

from __future__ import annotations

import copy
import json
import time

import numpy as np
import pytest

from benchmarks.blind import base
import benchmarks.rigtime.rt_c as rt
from benchmarks.rigtime.rt_c import thermal
from benchmarks.rigtime.rt_c.preisach import FastPhase


def _schedule(v, dwell, K=4, reading_s=0.2, measured=None):
    v = np.asarray(v, dtype=float)
    n = v.size
    return {"v_V": v, "dwell_s": np.broadcast_to(np.asarray(dwell, dtype=float), (n,)).copy(),
            "readings": np.full(n, K), "measured": np.ones(n, bool) if measured is None else measured,
            "reading_s": reading_s}


def _path(seed, n=120):
    rng = np.random.default_rng(seed)
    return np.concatenate([np.linspace(0, 6, 16), np.linspace(6, 2, 10), rng.uniform(0, 6, n)])


def test_fast_phase_equals_base_hysteresis():
    for seed in range(3):
        d = base.draw_device(seed)
        h, f = d.hysteresis(), FastPhase(d)
        xs = np.concatenate([_path(seed, 200), np.random.default_rng(seed).uniform(-1, 7, 100)])
        err = max(abs(h.move(x) - f.move(x)) for x in xs)
        assert err < 1e-9 * d.phase_swing_um


def test_instant_form_equals_clean_device():
    d = base.draw_device(4)
    v = _path(1)
    meas = np.ones(v.size, bool)
    meas[::3] = False
    for dwell in (0.0, 5.0):
        out = rt.simulate(d, _schedule(v, dwell, measured=meas), rt.instant_form(), 0, None)
        clean = base.clean_outputs(d, v)
        assert np.all(np.isnan(out["y_um"][~meas]))
        np.testing.assert_allclose(out["y_um"][meas], clean[meas], rtol=0, atol=1e-10)
    assert rt.settling_time_s(rt.instant_form(), 1e-3) == 0.0


@pytest.mark.parametrize("tau", [0.5, 3.0, 20.0])
def test_long_dwells_converge_to_clean(tau):
    d = base.draw_device(int(tau * 10))
    v = _path(2)
    clean = base.clean_outputs(d, v)
    for seed in range(3):
        form = rt.draw_form(tau, np.random.default_rng(seed), extras=False)
        ts = rt.settling_time_s(form, 1e-9)
        assert ts > tau
        out = rt.simulate(d, _schedule(v, ts), form, 0, None)
        assert np.max(np.abs(out["y_um"] - clean)) < 1e-6 * d.phase_swing_um


def test_form_family_and_tau_definition():
    for k, tau in enumerate([0.5, 1.0, 4.0, 20.0]):
        for seed in range(3):
            form = rt.draw_form(tau, np.random.default_rng(100 * k + seed))
            assert json.loads(json.dumps(form)) == form
            taus = np.asarray(form["tau_modes_s"])
            w = np.asarray(form["film_weights"])
            assert abs(w.sum() - 1) < 1e-9 and abs(np.sum(form["beam_weights"]) - 1) < 1e-9
            dom = taus[w >= thermal.DOMINANT_SHARE].max()
            assert dom == pytest.approx(tau, rel=1e-9)
            slower = taus > dom * (1 + 1e-9)
            assert np.all(taus[slower] <= 5 * tau) and np.sum(np.abs(w[slower])) <= 0.15
            # a passive network: monotone step response (no overshoot), for film and beam
            s = np.linspace(0, 30 * taus.max(), 2000)
            for ww in (w, np.asarray(form["beam_weights"])):
                res = thermal.residual(taus, ww, s)
                assert np.all(np.diff(res) <= 1e-12) and res[0] == pytest.approx(1.0)
            # settling grows as the tolerance tightens
            assert rt.settling_time_s(form, 1e-2) < rt.settling_time_s(form, 1e-4) < rt.settling_time_s(form, 1e-9)


def test_deterministic_and_noise_independent_of_form():
    d = base.draw_device(9)
    v = _path(3, 60)
    f1 = rt.draw_form(2.0, np.random.default_rng(1))
    f2 = rt.draw_form(2.0, np.random.default_rng(2))
    assert f1 == rt.draw_form(2.0, np.random.default_rng(1))
    sch = _schedule(v, 1.0)
    a = rt.simulate(d, sch, f1, 5, 0.05)
    b = rt.simulate(d, sch, f1, 5, 0.05)
    np.testing.assert_array_equal(a["y_um"], b["y_um"])
    np.testing.assert_array_equal(a["t_s"], b["t_s"])
    c = rt.simulate(d, sch, f1, 6, 0.05)
    assert np.max(np.abs(a["y_um"] - c["y_um"])) > 0
    n1 = a["y_um"] - rt.simulate(d, sch, f1, 5, None)["y_um"]
    n2 = rt.simulate(d, sch, f2, 5, 0.05)["y_um"] - rt.simulate(d, sch, f2, 5, None)["y_um"]
    np.testing.assert_allclose(n1, n2, atol=1e-12)


def test_short_dwell_differs_from_long():
    d = base.draw_device(11)
    v = _path(4, 40)
    form = rt.draw_form(3.0, np.random.default_rng(7), extras=False)
    long_ = rt.simulate(d, _schedule(v, rt.settling_time_s(form, 1e-9)), form, 0, None)["y_um"]
    short = rt.simulate(d, _schedule(v, 0.3), form, 0, None)["y_um"]
    assert np.max(np.abs(short - long_)) > 0.05 * d.phase_swing_um
    # the times: dwell then K readings per point, cumulative
    out = rt.simulate(d, _schedule(v, 0.3, K=3, reading_s=0.1), form, 0, None)
    np.testing.assert_allclose(np.diff(out["t_s"]), 0.6)


def test_noise_rms_per_point_when_still():
    d = base.draw_device(12)
    form = rt.draw_form(1.0, np.random.default_rng(3), extras=False)
    v = np.full(3000, 4.2)
    for K in (1, 4, 9):
        sch = _schedule(v, 0.0, K=K, reading_s=0.05)
        sch["dwell_s"][0] = rt.settling_time_s(form, 1e-9)
        free = rt.simulate(d, sch, form, 1, None)["y_um"]
        noisy = rt.simulate(d, sch, form, 1, 0.2)["y_um"]
        assert np.ptp(free) < 1e-9
        rms = np.std(noisy - free)
        assert rms == pytest.approx(0.2 / np.sqrt(K), rel=0.06)


def test_extras_are_small():
    d = base.draw_device(13)
    v = _path(5, 80)
    kinds = set()
    for seed in range(8):
        form = rt.draw_form(2.0, np.random.default_rng(seed), extras=True)
        kinds.add(form["extras"]["kind"])
        plain = copy.deepcopy(form)
        plain["extras"] = None
        sch = _schedule(v, 4.0)
        gap = rt.simulate(d, sch, form, 0, None)["y_um"] - rt.simulate(d, sch, plain, 0, None)["y_um"]
        assert 0 < np.max(np.abs(gap)) <= 1e-3 * d.phase_swing_um
    assert kinds == {"psd_drift", "creep"}


def test_transient_reading_average_matches_fine_quadrature():
    from benchmarks.rigtime.rt_c import sim
    d = base.draw_device(14)
    v = _path(6, 20)
    form = rt.draw_form(0.5, np.random.default_rng(21), extras=False)
    sch = _schedule(v, 0.0, K=3, reading_s=0.2)
    ours = rt.simulate(d, sch, form, 0, None)["y_um"]
    orig = sim._window_nodes

    def fine(a, b, *args):
        t = a + (np.arange(1500) + 0.5) / 1500 * (b - a)
        return t.tolist(), [1 / 1500] * 1500

    try:
        sim._window_nodes = fine
        ref = rt.simulate(d, sch, form, 0, None)["y_um"]
    finally:
        sim._window_nodes = orig
    assert np.max(np.abs(ours - ref)) < 2e-5 * d.phase_swing_um


def test_speed_500_points():
    d = base.draw_device(15)
    v = np.random.default_rng(0).uniform(0, 6, 500)
    form = rt.draw_form(2.0, np.random.default_rng(0))
    rt.simulate(d, _schedule(v[:10], 2.0), form, 0, None)
    t = time.perf_counter()
    rt.simulate(d, _schedule(v, 2.0, K=4, reading_s=0.2), form, 0, None)
    assert time.perf_counter() - t < 5.0       # a guard, not a benchmark: typically ~0.1 s on a quiet machine
