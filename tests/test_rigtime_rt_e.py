"""Tests of the rt_e rig-time device (benchmarks/rigtime/rt_e): thermal dynamics behind the base device."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.rigtime import rt_e
from benchmarks.rigtime.rt_e import model


def _schedule(v, dwell, readings=4, measured=None, reading_s=0.2):
    v = np.asarray(v, dtype=float)
    n = v.size
    return {
        "v_V": v,
        "dwell_s": np.broadcast_to(np.asarray(dwell, dtype=float), (n,)).copy(),
        "readings": np.broadcast_to(np.asarray(readings, dtype=int), (n,)).copy(),
        "measured": np.ones(n, bool) if measured is None else np.asarray(measured, bool),
        "reading_s": reading_s,
    }


def _path(rng, n):
    """Sweeps and random jumps over the whole range (nested loops and big steps)."""
    return np.concatenate([np.linspace(0.0, 6.0, n // 3), np.linspace(6.0, 2.0, n // 3),
                           rng.uniform(0.0, 6.0, n - 2 * (n // 3))])


@pytest.fixture(scope="module")
def forms():
    rng = np.random.default_rng(2024)
    return [rt_e.draw_form(tau, rng, extras=False) for tau in (0.5, 3.0, 12.0)]


def test_instant_form_equals_clean_device():
    rng = np.random.default_rng(1)
    for seed in range(3):
        device = base.draw_device(seed)
        v = _path(rng, 60)
        measured = rng.random(v.size) < 0.7
        sched = _schedule(v, rng.uniform(0.0, 5.0, v.size), rng.integers(0, 5, v.size), measured)
        out = rt_e.simulate(device, sched, rt_e.instant_form(), seed, None)
        clean = base.clean_outputs(device, v)
        ok = measured & (sched["readings"] > 0)
        assert np.array_equal(out["y_um"][ok], clean[ok])
        assert np.all(np.isnan(out["y_um"][~ok]))
        seg = sched["dwell_s"] + np.where(ok, sched["readings"], 0) * sched["reading_s"]
        assert np.allclose(out["t_s"], np.cumsum(seg))
        assert np.array_equal(out["v_V"], v)


def test_long_dwells_converge_to_clean_device(forms):
    rng = np.random.default_rng(2)
    for k, form in enumerate(forms):
        device = base.draw_device(10 + k)
        dwell = rt_e.settling_time_s(form, 1e-9)
        assert dwell > 5.0 * form["tau_s"]
        v = _path(rng, 45)
        out = rt_e.simulate(device, _schedule(v, dwell, 3, reading_s=0.3), form, k, None)
        err = np.max(np.abs(out["y_um"] - base.clean_outputs(device, v)))
        assert err <= 1e-6 * device.phase_swing_um


def test_deterministic_and_noise_from_seed_only(forms):
    device = base.draw_device(5)
    v = _path(np.random.default_rng(3), 40)
    sched = _schedule(v, 1.0)
    a = rt_e.simulate(device, sched, forms[0], 7, 0.05)
    b = rt_e.simulate(device, sched, json.loads(json.dumps(forms[0])), 7, 0.05)
    assert np.array_equal(a["y_um"], b["y_um"]) and np.array_equal(a["t_s"], b["t_s"])
    c = rt_e.simulate(device, sched, forms[0], 8, 0.05)
    assert not np.array_equal(a["y_um"], c["y_um"])
    # the noise does not depend on the form
    clean0 = rt_e.simulate(device, sched, forms[0], 7, None)["y_um"]
    clean1 = rt_e.simulate(device, sched, forms[1], 7, None)["y_um"]
    noisy1 = rt_e.simulate(device, sched, forms[1], 7, 0.05)["y_um"]
    assert np.allclose(a["y_um"] - clean0, noisy1 - clean1, rtol=0.0, atol=1e-12)
    # the same draw of a form from the same generator state
    f1 = rt_e.draw_form(2.0, np.random.default_rng(99))
    f2 = rt_e.draw_form(2.0, np.random.default_rng(99))
    assert f1 == f2


def test_short_dwell_differs_from_long(forms):
    device = base.draw_device(6)
    v = _path(np.random.default_rng(4), 30)
    for form in forms:
        long = rt_e.simulate(device, _schedule(v, 60.0 * form["tau_s"]), form, 0, None)["y_um"]
        short = rt_e.simulate(device, _schedule(v, 0.2 * form["tau_s"]), form, 0, None)["y_um"]
        assert np.max(np.abs(short - long)) > 0.02 * device.phase_swing_um


@pytest.mark.parametrize("K", [1, 4])
def test_noise_rms_when_film_still(forms, K):
    device = base.draw_device(8)
    form = forms[0]
    rng = np.random.default_rng(5)
    v = np.repeat(rng.uniform(0.0, 6.0, 50), 12)
    sched = _schedule(v, 60.0 * form["tau_s"], K)
    quiet = rt_e.simulate(device, sched, form, 11, None)["y_um"]
    noisy = rt_e.simulate(device, sched, form, 11, 0.2)["y_um"]
    rms = float(np.sqrt(np.mean((noisy - quiet) ** 2)))
    assert rms == pytest.approx(0.2 / math.sqrt(K), rel=0.08)


def test_form_is_json_safe_and_tau_is_the_slowest_carrying_mode():
    rng = np.random.default_rng(6)
    for tau in (0.5, 2.0, 20.0):
        form = rt_e.draw_form(tau, rng)
        assert json.loads(json.dumps(form)) == form
        taus, w = model._reference_modes(form)
        assert np.max(taus[w >= 0.2]) == pytest.approx(tau, rel=1e-9)
        assert np.max(taus) <= 8.0 * tau
        assert form["extra"]["kind"] in ("drift", "creep")
    assert rt_e.draw_form(1.0, rng, extras=False)["extra"]["kind"] == "none"
    assert rt_e.settling_time_s(rt_e.instant_form(), 1e-9) == 0.0


def test_steps_from_steady_state_are_monotone_and_physical(forms):
    """No overshoot of the film's temperature after a step from a steady state; plausible temperatures."""
    for k, form in enumerate(forms):
        device = base.draw_device(20 + k)
        net = model._device_net(form, device)
        vs = np.linspace(0.0, device.v_max_V, 9)
        th = net.steady(net.s * vs ** 2)
        assert np.all(np.diff(th, axis=0) > 0.0)  # hotter everywhere at a higher voltage
        assert device.ambient_C + th.max() < 200.0
        t = np.concatenate([[0.0], np.geomspace(1e-4, 50.0, 400)]) * form["tau_s"]
        for a in range(vs.size):
            for b in range(vs.size):
                if a == b:
                    continue
                C = net.C0.copy()
                C[net.jf] += net.latent * model._LATENT_RATIO_MAX * ((a + b) % 2)  # with and without latent heat
                lam, Phi, coef = net.segment(th[a], th[b], vs[b], C)
                path = th[b][None, :] + (np.exp(-np.outer(t, lam)) * coef) @ Phi.T
                step = th[b] - th[a]
                frac = (path - th[a]) / step
                assert frac.min() >= -1e-9 and frac.max() <= 1.0 + 1e-9
                d = np.diff(path[:, net.jf]) * np.sign(step[net.jf])
                assert d.min() >= -1e-9 * abs(step[net.jf])


def test_settling_time_bounds_the_device_and_extras_are_small():
    rng = np.random.default_rng(7)
    form = rt_e.draw_form(1.0, rng, extras=True)
    plain = dict(form, extra={"kind": "none"})
    device = base.draw_device(9)
    v = _path(np.random.default_rng(8), 30)
    sched = _schedule(v, rt_e.settling_time_s(plain, 1e-7))
    with_extra = rt_e.simulate(device, sched, form, 0, None)["y_um"]
    without = rt_e.simulate(device, sched, plain, 0, None)["y_um"]
    clean = base.clean_outputs(device, v)
    assert np.max(np.abs(without - clean)) <= 1e-4 * device.phase_swing_um
    assert 0.0 < np.max(np.abs(with_extra - without)) <= 1e-3 * device.phase_swing_um
    # looser tolerances settle sooner
    assert rt_e.settling_time_s(plain, 1e-2) < rt_e.settling_time_s(plain, 1e-6) < rt_e.settling_time_s(plain, 1e-9)


def test_speed_500_points():
    device = base.draw_device(12)
    form = rt_e.draw_form(2.0, np.random.default_rng(9))
    v = np.random.default_rng(10).uniform(0.0, 6.0, 500)
    sched = _schedule(v, 10.0, 4)
    start = time.process_time()
    out = rt_e.simulate(device, sched, form, 0, None)
    elapsed = time.process_time() - start
    assert np.all(np.isfinite(out["y_um"]))
    assert elapsed < 3.0  # typically ~0.3 s on an idle core


def test_phase_along_runs_is_the_exact_branch():
    """The per-node phases along monotone runs (grid levels and memory turning points as breaks)
    equal the hysteresis's own values."""
    device = base.draw_device(13)
    walker = model._Walker(device)
    rng = np.random.default_rng(14)
    x = 0.0
    for _ in range(40):
        target = float(rng.uniform(0.0, 6.0))
        end = x + (target - x) * float(rng.uniform(0.3, 1.0))
        xs = np.sort(rng.uniform(min(x, end), max(x, end), 25))
        xs = xs if end >= x else xs[::-1].copy()
        ref = walker.h.copy()
        exact = np.array([ref.peek(float(z)) for z in xs])
        if rng.random() < 0.5:
            got = walker.toward(xs, end, target, ref.peek(target))
            if got is None:
                got = walker.run(end, xs)
        else:
            got = walker.run(end, xs)
        assert np.max(np.abs(got - exact)) < 1e-6
        assert walker.x == end and walker.p == pytest.approx(ref.peek(end), abs=1e-12)
        x = end
