"""The rig-time device rt_a: the base device plus Foster-network thermal dynamics."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.rigtime import rt_a
from benchmarks.rigtime.rt_a.preisach import FastPreisach
from benchmarks.rigtime.rt_a.sim import _complement


def _schedule(v, dwell, readings=4, measured=True, reading_s=0.5):
    n = len(v)
    return {
        "v_V": np.asarray(v, float),
        "dwell_s": np.broadcast_to(np.asarray(dwell, float), (n,)).copy(),
        "readings": np.broadcast_to(np.asarray(readings, int), (n,)).copy(),
        "measured": np.broadcast_to(np.asarray(measured, bool), (n,)).copy(),
        "reading_s": reading_s,
    }


def _levels(rng, n, device):
    """Set-points on the grid's range, with returns to 0 V and to full scale."""
    v = rng.uniform(device.v_min_V, device.v_max_V, n)
    v[rng.random(n) < 0.1] = 0.0
    v[rng.random(n) < 0.05] = device.v_max_V
    return v


def _forms(tau, count, seed, extras=False):
    return [rt_a.draw_form(tau, np.random.default_rng([seed, i]), extras=extras) for i in range(count)]


def test_fast_preisach_is_the_base_hysteresis():
    for seed in range(3):
        device = base.draw_device(seed)
        rng = np.random.default_rng(seed)
        xs = np.concatenate([rng.uniform(-0.5, 6.5, 300), rng.integers(0, 31, 100) * 0.2,
                             3 + 2.5 * np.sin(np.arange(300) * 0.3) * np.exp(-np.arange(300) / 150)])
        ref, fast = device.hysteresis(), FastPreisach(device)
        a = np.array([ref.move(x) for x in xs])
        b = np.array([fast.move(x) for x in xs])
        assert np.max(np.abs(a - b)) <= 1e-12 * device.phase_swing_um


def test_instant_form_is_the_clean_device():
    device = base.draw_device(11)
    rng = np.random.default_rng(1)
    v = _levels(rng, 300, device)
    sched = _schedule(v, rng.uniform(0, 3, 300) * (rng.random(300) < 0.7), rng.integers(1, 5, 300),
                      rng.random(300) < 0.8)
    out = rt_a.simulate(device, sched, rt_a.instant_form(), 3, None)
    clean = base.clean_outputs(device, v)
    m = sched["measured"]
    assert np.all(np.isnan(out["y_um"][~m]))
    assert np.max(np.abs(out["y_um"][m] - clean[m])) <= 1e-12 * device.phase_swing_um
    assert json.loads(json.dumps(rt_a.instant_form())) == rt_a.instant_form()


@pytest.mark.parametrize("tau", [0.5, 4.0, 20.0])
def test_long_dwells_converge_to_the_clean_device(tau):
    for k, form in enumerate(_forms(tau, 4, int(tau * 10))):
        device = base.draw_device(20 + k)
        rng = np.random.default_rng(k)
        v = _levels(rng, 80, device)
        dwell = rt_a.settling_time_s(form, 1e-9)
        out = rt_a.simulate(device, _schedule(v, dwell, 2, True, 0.3), form, 0, None)
        clean = base.clean_outputs(device, v)
        assert np.max(np.abs(out["y_um"] - clean)) <= 1e-6 * device.phase_swing_um


def test_determinism_and_noise_independent_of_the_form():
    device = base.draw_device(4)
    rng = np.random.default_rng(2)
    v = _levels(rng, 120, device)
    sched = _schedule(v, rng.uniform(0, 8, 120), rng.integers(1, 6, 120), rng.random(120) < 0.9)
    f1, f2 = _forms(5.0, 2, 7, extras=True)
    a = rt_a.simulate(device, sched, f1, 5, 0.05)
    b = rt_a.simulate(device, sched, f1, 5, 0.05)
    for key in ("t_s", "v_V", "y_um"):
        np.testing.assert_array_equal(a[key], b[key])
    c = rt_a.simulate(device, sched, f1, 6, 0.05)
    m = sched["measured"]
    assert not np.allclose(a["y_um"][m], c["y_um"][m])
    noise1 = a["y_um"] - rt_a.simulate(device, sched, f1, 5, None)["y_um"]
    noise2 = rt_a.simulate(device, sched, f2, 5, 0.05)["y_um"] - rt_a.simulate(device, sched, f2, 5, None)["y_um"]
    np.testing.assert_allclose(noise1[m], noise2[m], atol=1e-12)


def test_short_dwell_differs_from_long_dwell():
    device = base.draw_device(8)
    rng = np.random.default_rng(3)
    v = _levels(rng, 60, device)
    for form in _forms(3.0, 4, 9):
        short = rt_a.simulate(device, _schedule(v, 0.5), form, 0, None)["y_um"]
        long_ = rt_a.simulate(device, _schedule(v, rt_a.settling_time_s(form, 1e-9)), form, 0, None)["y_um"]
        assert np.sqrt(np.mean((short - long_) ** 2)) > 0.05 * device.phase_swing_um


def test_noise_rms_per_point_when_the_film_is_still():
    device = base.draw_device(5)
    n, K, noise = 3000, 4, 0.2
    v = np.full(n, 3.0)
    form = _forms(1.0, 1, 3)[0]
    sched = _schedule(v, 0.0, K)
    sched["dwell_s"][0] = rt_a.settling_time_s(form, 1e-12)  # then the film is still
    clean = rt_a.simulate(device, sched, form, 1, None)["y_um"]
    noisy = rt_a.simulate(device, sched, form, 1, noise)["y_um"]
    assert np.ptp(clean) <= 1e-9
    rms = np.sqrt(np.mean((noisy - clean) ** 2))
    assert abs(rms / (noise / math.sqrt(K)) - 1.0) < 0.06


def test_times_and_unmeasured_points():
    device = base.draw_device(6)
    v = np.array([1.0, 4.0, 5.0, 2.0])
    sched = _schedule(v, [2.0, 0.0, 3.0, 1.0], [3, 2, 5, 1], [True, True, False, True], 0.25)
    out = rt_a.simulate(device, sched, _forms(2.0, 1, 1)[0], 0, 0.1)
    np.testing.assert_allclose(out["t_s"], np.cumsum([2.75, 0.5, 3.0, 1.25]))
    assert np.isnan(out["y_um"][2]) and np.all(np.isfinite(out["y_um"][[0, 1, 3]]))
    np.testing.assert_array_equal(out["v_V"], v)


def test_forms_tau_s_and_no_overshoot():
    for tau in (0.5, 2.0, 7.0, 20.0):
        for form in _forms(tau, 30, 42, extras=True):
            assert json.loads(json.dumps(form)) == form
            taus = np.array(form["modes_tau_s"])
            w = np.array(form["film_weights"])
            assert np.all(w > 0) and abs(w.sum() - 1) < 1e-12 and np.all(np.array(form["beam_weights"]) > 0)
            # tau_s: the slowest mode carrying >= 20 % of the steady rise
            assert taus[w >= 0.2].max() == pytest.approx(tau, rel=1e-12)
            assert taus.max() <= 4.0 * tau
            # a step from steady state never overshoots: 1 - step response decreases from 1 to 0
            for lag, ww in ((form["film_lag_s"], w), (form["beam_lag_s"], np.array(form["beam_weights"]))):
                tt, cc = _complement(taus, ww, lag)
                t = np.concatenate([[0.0], np.geomspace(1e-4 * tau, 200 * tau, 4000)])
                g = np.exp(-np.multiply.outer(t, 1.0 / tt)) @ cc
                assert g[0] == pytest.approx(1.0) and np.all(np.diff(g) <= 1e-12) and g[-1] < 1e-6
            # the settling time bounds the remaining fraction (of a step down to 0 V: sqrt of the rise's)
            tt, cc = _complement(taus, w, form["film_lag_s"])
            for tol in (1e-2, 1e-6):
                ts = rt_a.settling_time_s(form, tol)
                rest = float(np.exp(-ts * 0.999 / tt / (form["latent_max_stretch"] / min(
                    rt_a.sim._rate_factor(form, 0), rt_a.sim._rate_factor(form, 150.0)))) @ cc)
                assert math.sqrt(rest) > tol * 0.999
                assert math.sqrt(max(float(np.exp(-ts / tt) @ cc), 0)) <= tol * 1.001
            extra = form["extra"]
            assert extra is not None and extra["kind"] in ("drift", "creep")


def test_extremes_of_the_path_are_followed():
    """Splitting a set-point into several with the same voltage (no latent heat) changes nothing:
    the hysterons see every extreme of the film's path, not only the sampled points."""
    device = base.draw_device(9)
    rng = np.random.default_rng(4)
    n, N = 100, 6
    v = _levels(rng, n, device)
    dwell = rng.uniform(0, 6, n)
    for form in _forms(3.0, 5, 13):
        form = dict(form, latent_K=0.0, latent_max_stretch=1.0)
        whole = rt_a.simulate(device, _schedule(v, dwell, 2, True, 0.3), form, 0, None)["y_um"]
        measured = np.zeros(n * N, bool)
        measured[N - 1::N] = True
        split = _schedule(np.repeat(v, N), np.repeat(dwell / N, N), 2 * measured, measured, 0.3)
        parts = rt_a.simulate(device, split, form, 0, None)["y_um"][N - 1::N]
        assert np.max(np.abs(whole - parts)) <= 1e-10 * device.phase_swing_um


def test_extras_are_small():
    device = base.draw_device(10)
    rng = np.random.default_rng(5)
    v = _levels(rng, 200, device)
    sched = _schedule(v, rng.uniform(0, 30, 200), 3)
    kinds = set()
    for form in _forms(4.0, 8, 17, extras=True):
        kinds.add(form["extra"]["kind"])
        with_ = rt_a.simulate(device, sched, form, 0, None)["y_um"]
        without = rt_a.simulate(device, sched, dict(form, extra=None), 0, None)["y_um"]
        gap = np.max(np.abs(with_ - without))
        assert 0 < gap <= 1e-3 * device.phase_swing_um
    assert kinds == {"drift", "creep"}


def test_speed_500_setpoints():
    device = base.draw_device(12)
    rng = np.random.default_rng(6)
    v = _levels(rng, 500, device)
    form = _forms(5.0, 1, 21, extras=True)[0]
    sched = _schedule(v, rng.uniform(0, 10, 500), 4)
    rt_a.simulate(device, sched, form, 0, None)
    best = min(_timed(rt_a.simulate, device, sched, form, 0, None) for _ in range(2))
    assert best < 5.0  # a guard against a pathological slow-down, not a benchmark (a loaded CI machine)


def _timed(fn, *args) -> float:
    t = time.perf_counter()
    fn(*args)
    return time.perf_counter() - t
