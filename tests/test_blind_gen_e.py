"""Tests of the blind generator ``benchmarks.blind.gen_e`` (SPEC.md): exactness at strength 0, determinism,
every mechanism acting, strength-free realisations, and one hand-checkable physical property per mechanism."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_e
from benchmarks.blind.gen_e import schedules
from benchmarks.blind.gen_e._kernels import kernel_function, prony
from benchmarks.blind.gen_e._session import DAQ_SAMPLE_S, device_scale
from benchmarks.blind.gen_e._thermal import ThermalNetwork

ALL = gen_e.LIBRARY + gen_e.OUTSIDE


@pytest.fixture(scope="module")
def device():
    return base.draw_device(11)


@pytest.fixture(scope="module")
def short_session():
    """The identification run and a shortened check run (keeps the suite fast)."""
    return [schedules.identification(), schedules.check(4, n=120)]


@pytest.fixture(scope="module")
def clean(device, short_session):
    return gen_e.simulate(device, short_session, [], 0, None)


def _run(v, dwell, readings=10):
    v = np.asarray(v, float)
    return {"v_V": v, "dwell_s": np.broadcast_to(np.asarray(dwell, float), v.shape).copy(), "readings": readings}


def _form(family, i=0):
    return gen_e.draw_form(family, np.random.default_rng([i, 2026]))


def _dev(out, ref):
    return np.concatenate([a["y_um"] - b["y_um"] for a, b in zip(out, ref)])


# ------------------------------------------------------------------------------------------------ interface
def test_names():
    assert gen_e.LIBRARY == ("thermal_lag", "creep", "baseline_drift", "ambient_drift", "joule_power",
                             "sensor_nonlinearity", "reversible", "interaction", "first_point", "gain_drift")
    assert set(gen_e.OUTSIDE) >= {"backlash", "accommodation"} and len(gen_e.OUTSIDE) == 3
    assert not set(gen_e.OUTSIDE) & set(gen_e.LIBRARY)


def test_forms_json_safe_and_reproducible():
    for fam in ALL:
        for i in range(6):
            a = gen_e.draw_form(fam, np.random.default_rng(i))
            b = gen_e.draw_form(fam, np.random.default_rng(i))
            assert json.loads(json.dumps(a)) == a == b
    with pytest.raises(ValueError):
        gen_e.draw_form("nonsense", np.random.default_rng(0))


def test_outputs_and_logger(device, short_session, clean):
    for out, sch in zip(clean, short_session):
        n = sch["v_V"].size
        assert set(out) == {"t_s", "v_V", "y_um", "dwell_s"}
        assert all(out[k].shape == (n,) for k in out)
        burst = sch["readings"] * DAQ_SAMPLE_S
        np.testing.assert_allclose(out["dwell_s"], sch["dwell_s"] + burst / 2)
        # readings follow each other by (dwell + burst); the first one a dwell after the run's start
        np.testing.assert_allclose(np.diff(out["t_s"]), sch["dwell_s"][1:] + burst)
        assert out["t_s"][0] == pytest.approx(out["dwell_s"][0])


# ------------------------------------------------------------------------------------------------ SPEC rules
def test_strength_zero_is_clean_bit_for_bit(device, short_session):
    effects = [(fam, _form(fam), 0.0) for fam in ALL]
    for effs in ([], effects):
        out = gen_e.simulate(device, short_session, effs, 123, None)
        for o, sch in zip(out, short_session):
            assert np.array_equal(o["y_um"], base.clean_outputs(device, sch["v_V"]))


def test_determinism(device, short_session):
    effects = [("thermal_lag", _form("thermal_lag", 1), 1.0), ("baseline_drift", _form("baseline_drift", 1), 0.7),
               ("interaction", _form("interaction", 1), 1.3), ("backlash", _form("backlash", 1), 1.0)]
    a = gen_e.simulate(device, short_session, effects, 9, 0.02)
    b = gen_e.simulate(device, short_session, effects, 9, 0.02)
    c = gen_e.simulate(device, short_session, effects, 10, 0.02)
    for x, y in zip(a, b):
        for k in x:
            assert np.array_equal(x[k], y[k])
    assert not np.array_equal(a[1]["y_um"], c[1]["y_um"])


@pytest.mark.parametrize("family", ALL)
def test_every_mechanism_changes_the_output(family, device, short_session, clean):
    swing = device_scale(device)["swing"]
    out = gen_e.simulate(device, short_session, [(family, _form(family, 3), 1.0)], 5, None)
    d = _dev(out, clean)
    assert np.max(np.abs(d)) > 1e-3 * swing          # visible ...
    assert np.max(np.abs(d)) < 0.10 * swing          # ... and physical (a few % at strength 1)
    # and it grows with the strength
    half = _dev(gen_e.simulate(device, short_session, [(family, _form(family, 3), 0.5)], 5, None), clean)
    assert np.sqrt(np.mean(half**2)) < np.sqrt(np.mean(d**2))


def test_noise_independent_of_effects(device, short_session, clean):
    eff = [("joule_power", _form("joule_power"), 1.0)]
    quiet = gen_e.simulate(device, short_session, eff, 4, None)
    noisy = gen_e.simulate(device, short_session, eff, 4, 0.05)
    noisy0 = gen_e.simulate(device, short_session, [], 4, 0.05)
    n1, n0 = _dev(noisy, quiet), _dev(noisy0, clean)
    np.testing.assert_allclose(n1, n0, atol=1e-12)
    assert 0.04 < np.std(n0) < 0.06


def test_drift_realisations_independent_of_strength_and_company(device, short_session, clean):
    fb, fg, fj = _form("baseline_drift", 2), _form("gain_drift", 2), _form("joule_power", 2)
    b1 = _dev(gen_e.simulate(device, short_session, [("baseline_drift", fb, 1.0)], 8, None), clean)
    b3 = _dev(gen_e.simulate(device, short_session, [("baseline_drift", fb, 3.0)], 8, None), clean)
    np.testing.assert_allclose(b3, 3.0 * b1, atol=1e-9)           # same path, scaled
    # the same baseline path when another mechanism is present (it acts last, additively)
    j = gen_e.simulate(device, short_session, [("joule_power", fj, 1.0)], 8, None)
    jb = gen_e.simulate(device, short_session, [("joule_power", fj, 1.0), ("baseline_drift", fb, 1.0)], 8, None)
    np.testing.assert_allclose(_dev(jb, j), b1, atol=1e-9)
    # gain: log of the gain factor scales with the strength
    sc = device_scale(device)
    uz = sc["mid"] + fg["zero_offset"] * sc["U"]
    y0 = np.concatenate([o["y_um"] for o in clean]) - uz
    keep = np.abs(y0) > 0.05 * sc["swing"]
    g1 = np.concatenate([o["y_um"] for o in gen_e.simulate(device, short_session, [("gain_drift", fg, 1.0)], 8, None)]) - uz
    g2 = np.concatenate([o["y_um"] for o in gen_e.simulate(device, short_session, [("gain_drift", fg, 2.0)], 8, None)]) - uz
    np.testing.assert_allclose(np.log(g2[keep] / y0[keep]), 2.0 * np.log(g1[keep] / y0[keep]), atol=1e-9)


# ------------------------------------------------------------------------------------------------ physics
def test_thermal_node_reaches_one_minus_1_over_e_at_its_time_constant():
    form = {"node_tau_s": [100.0], "resistance_share": [1.0], "tcr_per_K": 0.0, "series_ratio": 1.0,
            "convective_weight": 0.0, "radiative_weight": 0.0}
    net = ThermalNetwork(2.0, 25.0, form, 0.1)
    D = net.drive(4.0)
    tb = net.trajectory(D, np.array([1e-9, 100.0, 1.0e5]))
    assert tb[0] == pytest.approx(0.9 * 32.0, rel=1e-6)              # the beam's own (fast) share
    assert tb[2] == pytest.approx(32.0, rel=1e-9)                     # steady state = rise_K(v) = k v^2
    assert (tb[1] - tb[0]) / (tb[2] - tb[0]) == pytest.approx(1 - np.exp(-1), rel=1e-9)


def test_thermal_network_nonlinear_steady_state_and_diffusive_sqrt_t():
    form = {"node_tau_s": [36.0] * 10, "resistance_share": [0.1] * 10, "tcr_per_K": 3e-3, "series_ratio": 0.3,
            "convective_weight": 0.3, "radiative_weight": 0.2}
    net = ThermalNetwork(2.0, 25.0, form, 0.1)
    D = net.drive(4.0)
    ts = np.concatenate([[1e-6], 2.0 ** np.arange(0, 13), 4096 + 60.0 * np.arange(1, 1500)])
    tb = net.trajectory(D, ts)
    assert tb[-1] == pytest.approx(32.0, rel=1e-6)                    # calibrated steady state, despite TCR etc.
    rise = tb - tb[0]
    ratio = rise[8:12] / rise[7:11]                                    # t = 128 .. 1024 s: sqrt(t) regime
    assert np.all((ratio > 1.3) & (ratio < 1.7))


def test_creep_single_branch_decays_as_its_exponential(device):
    sch = [_run([6.0], 150.0)]
    form = {"kernel": "prony", "tau_s": [150.0], "weights": [1.0], "driver": "phase", "size_law": "linear",
            "size_power": 1.0, "saturation_frac": 0.3, "sign": 1, "down_ratio": 1.0, "amplitude_at_1": 0.02}
    y = gen_e.simulate(device, sch, [("creep", form, 1.0)], 0, None)[0]["y_um"]
    y0 = base.clean_outputs(device, [6.0])
    step = 2.0 * device.phase_swing_um                                 # insulating -> metallic
    t = 150.0 + 10 * DAQ_SAMPLE_S / 2
    # forward creep: the reading is short of its relaxed value by A * step * exp(-t / tau)
    assert y[0] - y0[0] == pytest.approx(-0.02 * step * np.exp(-t / 150.0), rel=1e-9)


def test_creep_kernels_match_their_laws():
    t = np.array([0.0, 10.0, 100.0, 1000.0, 10000.0])
    for form in ({"kernel": "power_law", "tau0_s": 5.0, "exponent": 0.3},
                 {"kernel": "lognormal", "median_tau_s": 100.0, "sigma_ln": 1.5},
                 {"kernel": "stretched_exp", "tau_s": 200.0, "beta": 0.7}):
        w, tau = prony(form)
        assert np.all(w >= 0) and w.sum() == pytest.approx(1.0)
        np.testing.assert_allclose(np.exp(-t[:, None] / tau[None, :]) @ w, kernel_function(form, t), atol=0.03)


def test_baseline_is_additive_and_independent_of_the_input(device):
    times = [_run(np.full(50, 0.0), 30.0)]
    other = [_run(np.linspace(0, 6, 50), 30.0)]
    f = _form("baseline_drift", 4)
    d1 = gen_e.simulate(device, times, [("baseline_drift", f, 1.0)], 2, None)[0]["y_um"] - base.clean_outputs(device, times[0]["v_V"])
    d2 = gen_e.simulate(device, other, [("baseline_drift", f, 1.0)], 2, None)[0]["y_um"] - base.clean_outputs(device, other[0]["v_V"])
    np.testing.assert_allclose(d1, d2, atol=1e-12)


def test_ambient_drift_only_moves_the_hysterons(device):
    f = _form("ambient_drift", 1)
    cold = [_run(np.zeros(40), 60.0)]                                  # film saturated, thermal term at 0 V
    y = gen_e.simulate(device, cold, [("ambient_drift", f, 1.0)], 3, None)[0]["y_um"]
    np.testing.assert_allclose(y, base.clean_outputs(device, cold[0]["v_V"]), atol=1e-6)
    # in the transition it is an input shift: a warmer room moves the film towards the metallic state
    sweep = [_run(np.linspace(0, 6, 121), 20.0)]
    f = {"family": "ambient_drift", "components": [{"kind": "trend", "weight": 1.0, "sign": 1, "curvature": 0.0}],
         "package_tau_s": 60.0, "peak_K_at_1": 0.2}
    y = gen_e.simulate(device, sweep, [("ambient_drift", f, 1.0)], 3, None)[0]["y_um"]
    d = y - base.clean_outputs(device, sweep[0]["v_V"])
    late = slice(80, None)                                             # the trend is warm in the second half
    assert np.all(d[late] >= -1e-9) and d.max() > 0


def test_joule_power_pure_square_law(device):
    v = np.linspace(0, 6, 25)
    sch = [_run(v, 20.0)]
    f = {"family": "joule_power", "beta": 0.0, "step": 0.0, "step_width_K": 0.0, "peak_frac_at_1": 0.01}
    y = gen_e.simulate(device, sch, [("joule_power", f, 1.0)], 0, None)[0]["y_um"]
    d = y - base.clean_outputs(device, v)
    # the bimorph follows k v^2: the term becomes thermal * (v + m (v^2 / v_max - v)), unchanged at 0 and v_max;
    # m = 1 - exp(-strength * m1), m1 such that the peak deviation (at v_max / 2) is 1 % of the swing
    m1 = 0.01 * device_scale(device)["swing"] / (abs(device.thermal_um_per_V) * 1.5)
    m = -np.expm1(-m1)
    np.testing.assert_allclose(d, m * device.thermal_um_per_V * (v**2 / 6.0 - v), atol=1e-9)


def test_sensor_nonlinearity_monotone_and_compressive_quadrant(device):
    v = np.concatenate([np.linspace(0, 6, 61), np.linspace(6, 0, 61)])
    sch = [_run(v, 20.0)]
    f = {"family": "sensor_nonlinearity", "kind": "quadrant", "sign": 1, "zero_offset": 0.3, "peak_frac_at_1": 0.02}
    y = gen_e.simulate(device, sch, [("sensor_nonlinearity", f, 1.0)], 0, None)[0]["y_um"]
    u = base.clean_outputs(device, v)
    sc = device_scale(device)
    uc = sc["mid"] + 0.3 * sc["U"]
    assert np.all(np.abs(y - uc) <= np.abs(u - uc) + 1e-12)           # a split photodiode compresses
    order = np.argsort(u)
    assert np.all(np.diff(y[order]) >= 0)                              # and keeps the order (monotone)
    assert np.max(np.abs(y - u)) == pytest.approx(0.02 * sc["swing"], rel=0.1)


def test_reversible_is_single_valued(device):
    v = np.array([3.0, 6.0, 3.0, 0.0, 3.0, 4.5, 3.0])                 # 3 V on different branches
    sch = [_run(v, 20.0)]
    f = _form("reversible", 2)
    d = gen_e.simulate(device, sch, [("reversible", f, 1.0)], 0, None)[0]["y_um"] - base.clean_outputs(device, v)
    np.testing.assert_allclose(d[[0, 2, 4, 6]], d[0], atol=1e-12)
    assert d[3] == pytest.approx(0.0, abs=1e-12)                       # zero at rest


def test_interaction_mean_field_slope_is_one_over_one_minus_gain(device):
    v = np.linspace(0, 6, 241)
    sch = [_run(v, 20.0)]
    clean = base.clean_outputs(device, v) - device.thermal_um_per_V * v
    for sign in (1, -1):
        s = 10.0
        f = {"family": "interaction", "units": "voltage", "sign": sign, "gain_at_1": 0.05, "quadratic": 0.0,
             "reference": "midpoint"}
        y = gen_e.simulate(device, sch, [("interaction", f, s)], 0, None)[0]["y_um"] - device.thermal_um_per_V * v
        g = 0.8 * -np.expm1(-s * 0.05 / 0.8)
        ratio = np.max(np.diff(y)) / np.max(np.diff(clean))
        assert ratio == pytest.approx(1.0 / (1.0 - sign * g), rel=0.02)


def test_first_point_offsets_only_after_reversals(device):
    f = {"family": "first_point", "amp_up_frac_at_1": 0.02, "amp_down_frac_at_1": -0.01, "size_law": "power",
         "v0_V": 0.1, "power": 1.0, "threshold_V": 0.1, "threshold_width_V": 0.05, "linger": 2, "linger_ratio": 0.5}
    mono = [_run(np.linspace(0.5, 6, 12), 20.0)]
    y = gen_e.simulate(device, mono, [("first_point", f, 1.0)], 0, None)[0]["y_um"]
    np.testing.assert_array_equal(y, base.clean_outputs(device, mono[0]["v_V"]))
    v = np.array([1.0, 2.0, 5.0, 4.0, 3.0, 2.0, 1.0])                 # one reversal (down) at index 3
    y = gen_e.simulate(device, [_run(v, 20.0)], [("first_point", f, 1.0)], 0, None)[0]["y_um"]
    d = y - base.clean_outputs(device, v)
    a = -0.01 * device_scale(device)["swing"] * (1.0 / 6.0)           # size (|dv| / v_max)^1
    np.testing.assert_allclose(d, [0, 0, 0, a, 0.5 * a, 0.25 * a, 0], atol=1e-12)


def test_gain_drift_is_a_common_factor(device):
    f = _form("gain_drift", 5)
    sc = device_scale(device)
    uz = sc["mid"] + f["zero_offset"] * sc["U"]
    va, vb = np.linspace(0, 6, 40), np.linspace(6, 0, 40)
    ua, ub = base.clean_outputs(device, va) - uz, base.clean_outputs(device, vb) - uz
    ya = gen_e.simulate(device, [_run(va, 30.0)], [("gain_drift", f, 1.0)], 6, None)[0]["y_um"] - uz
    yb = gen_e.simulate(device, [_run(vb, 30.0)], [("gain_drift", f, 1.0)], 6, None)[0]["y_um"] - uz
    keep = (np.abs(ua) > 0.01 * sc["swing"]) & (np.abs(ub) > 0.01 * sc["swing"])
    # same time -> same factor, whatever the input; bounded by the form's peak
    np.testing.assert_allclose(ya[keep] / ua[keep], yb[keep] / ub[keep], rtol=1e-9)
    assert np.all(np.abs(np.log(ya[keep] / ua[keep])) <= f["peak_rel_at_1"] + 1e-12)
    assert np.ptp(ya[keep] / ua[keep]) > 0


def test_backlash_holds_the_reading_inside_the_play(device):
    f = {"family": "backlash", "kind": "single", "widths_rel": [1.0], "weights": [1.0], "half_play_frac_at_1": 0.01,
         "asymmetry": 0.0, "initial_side": 0}
    v = np.array([0.0, 0.3, 0.0, 0.3, 0.0])                            # thermal excursions smaller than the play
    u = base.clean_outputs(device, v)
    b = 5.0 * 0.01 * device_scale(device)["swing"]
    assert np.ptp(u) < b
    y = gen_e.simulate(device, [_run(v, 20.0)], [("backlash", f, 5.0)], 0, None)[0]["y_um"]
    np.testing.assert_allclose(y, y[0], atol=1e-12)                     # the mount never moves
    # a large move drags it: the reading lags the deflection by the play
    v = np.array([0.0, 6.0])
    u = base.clean_outputs(device, v)
    y = gen_e.simulate(device, [_run(v, 20.0)], [("backlash", f, 5.0)], 0, None)[0]["y_um"]
    assert abs(y[1] - u[1]) == pytest.approx(b, rel=1e-9)


def test_accommodation_uniform_mask_scales_the_phase_with_cycles(device):
    f = {"family": "accommodation", "mask": "uniform", "mask_sign": 1, "kinetics": "saturating",
         "cycles_scale": 5.0, "power": 1.0, "amplitude_at_1": 0.05, "mask_seed": 0}
    v = np.tile([6.0, 0.0], 15)
    y = gen_e.simulate(device, [_run(v, 20.0)], [("accommodation", f, 1.0)], 0, None)[0]["y_um"]
    d = y - base.clean_outputs(device, v)
    S = device.phase_swing_um
    # at the saturated ends the deviation is e(N) * (+-S); e grows with every cycle (training)
    e_hot, e_cold = d[0::2] / S, -d[1::2] / S
    assert e_hot[0] > 0
    assert np.all(np.diff(e_hot) > 0) and np.all(np.diff(e_cold) > 0)
    N = np.arange(1, 16)                                               # one full cycle per pair of set-points
    expect = 0.9 * np.tanh(0.05 * -np.expm1(-(N - 0.5) / 5.0) / -np.expm1(-10.0 / 5.0) / 0.9)
    np.testing.assert_allclose(e_hot, expect, rtol=1e-6)


def test_heater_aging_starts_clean_and_acts_like_a_power_change(device):
    f = {"family": "heater_aging", "activation_eV": 0.8, "hotspot_factor": 1.2, "kinetics": "first_order",
         "dose_scale_h": 0.5, "sign": 1, "power_change_at_1": 0.01}
    v = np.concatenate([np.full(60, 6.0), np.linspace(0, 6, 61)])
    sch = [_run(v, 60.0)]
    y = gen_e.simulate(device, sch, [("heater_aging", f, 1.0)], 0, None)[0]["y_um"]
    u = base.clean_outputs(device, v)
    assert y[0] == pytest.approx(u[0], abs=1e-9)                       # no dose yet
    # second set-point: one dwell at full power is a dose of (60 s + burst) at the reference rate (1); the power
    # factor exp(eps) raises the rise by exp(eps): only the bimorph term changes (the film is metallic anyway)
    dose = (60.0 + 10 * DAQ_SAMPLE_S) / 3600.0
    eps = 0.01 * -np.expm1(-dose / 0.5) / -np.expm1(-0.5 / 0.5)
    assert y[1] - u[1] == pytest.approx(device.thermal_um_per_V * 6.0 * (np.exp(eps / 2) - 1.0), rel=1e-6)
    # after an hour at full power the heater gives more power: on the following ramp the film transforms earlier
    assert np.max((y - u)[60:]) > 0.01 * device_scale(device)["swing"]
