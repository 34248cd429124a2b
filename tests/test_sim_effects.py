"""The built-in unmodelled effects of the simulated device, each against a hand-computed value."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers import VirtualClock
from drivers.sim import EFFECTS, SimParams, SimVO2
from drivers.sim.builtin_effects import SmoothDrift
from drivers.sim.builtin_effects import make_effects

QUIET = dict(psd_noise_V=0.0, levels=12)


def device(effects: dict, **params) -> tuple[SimVO2, VirtualClock]:
    clock = VirtualClock()
    return SimVO2(SimParams(**QUIET, **params, effects=effects), clock), clock


def at(dev: SimVO2, clock: VirtualClock, schedule: list[tuple[float, float]]) -> list[float]:
    """Apply each (volts, dwell) and read the noise-free deflection (um) after each dwell."""
    out = []
    for v, dwell in schedule:
        dev.apply_voltage(v)
        clock.sleep(dwell)
        out.append(dev.deflection_um())
    return out


def test_every_effect_is_registered_and_off_by_default():
    assert set(EFFECTS) >= {"thermal_lag", "baseline_drift", "ambient_drift", "joule_power", "creep",
                            "sensor_nonlinearity"}
    assert SimVO2(SimParams()).effects == []
    assert make_effects({"creep": 0.0}) == []


def test_thermal_lag_is_a_slow_mode_of_the_rise_and_leaves_the_steady_state_alone():
    a, tau, v = 0.2, 5.0, 4.0
    dev, clock = device({"thermal_lag": {"strength": a, "time_constant_s": tau}})
    dev.apply_voltage(v)
    clock.sleep(8.0)  # the fast mode (0.5 s) is nearly settled, the slow one is not
    target = dev.params.steady_rise_K(v)
    fast = target * (1 - math.exp(-8.0 / dev.params.time_constant_s))
    expected_rise = (1 - a) * fast + a * target * (1 - math.exp(-8.0 / tau))
    assert dev.state().effects["thermal_lag"]["slow_rise_K"] == pytest.approx(target * (1 - math.exp(-8.0 / tau)))
    assert dev.state().preisach_input_V == pytest.approx(dev.params.equivalent_voltage(expected_rise), rel=1e-9)
    # after 60 time constants the device is back on equation (22)
    clock.sleep(300.0)
    assert dev.deflection_um() == pytest.approx(dev.true_model().predict(np.array([v]))[0], abs=1e-9)
    with pytest.raises(ValueError, match="fraction"):
        make_effects({"thermal_lag": 1.5})


def test_baseline_drift_moves_the_psd_zero_by_a_seeded_unit_rms_process():
    drift = SmoothDrift(3, 1800.0, 14400.0, salt=1)
    t = np.linspace(0, 2e6, 200_001)
    values = np.array([drift(x) for x in t[::50]])
    assert np.sqrt(np.mean(values**2)) == pytest.approx(1.0, rel=0.1)
    dev, clock = device({"baseline_drift": {"strength": 0.01, "seed": 3}})
    dev.apply_voltage(2.0)
    clock.sleep(1000.0)
    plain = SimVO2(SimParams(**QUIET))
    plain_psd = plain.true_model().predict(np.array([2.0]))[0] / dev.params.psd_um_per_V
    assert dev.read_psd() - plain_psd == pytest.approx(0.01 * drift(1000.0), abs=1e-12)
    other = SmoothDrift(4, 1800.0, 14400.0, salt=1)
    assert drift(1000.0) != other(1000.0)


def test_ambient_drift_shifts_the_preisach_input_through_the_temperature():
    dev, clock = device({"ambient_drift": {"strength": 0.5, "seed": 1}})
    dev.apply_voltage(4.0)
    clock.sleep(50.0)
    p = dev.params
    d_t = 0.5 * SmoothDrift(1, 1800.0, 14400.0, salt=2)(50.0)
    st = dev.state()
    assert st.preisach_input_V == pytest.approx(p.equivalent_voltage(p.steady_rise_K(4.0) + d_t), rel=1e-12)
    assert st.thermal_um == pytest.approx(p.thermal_um_per_V * 4.0)  # the heater's term is not shifted


def test_joule_power_adds_expansion_in_proportion_to_the_temperature_rise():
    dev, clock = device({"joule_power": 0.02})
    out = at(dev, clock, [(3.0, 30.0), (5.0, 30.0)])
    truth = dev.true_model().predict(np.array([3.0, 5.0]))
    k = dev.params.kelvin_per_V2
    np.testing.assert_allclose(np.array(out) - truth, [0.02 * k * 9.0, 0.02 * k * 25.0], rtol=1e-9)


def test_creep_relaxes_after_each_reversal_as_a_stretched_exponential():
    s, tau = 0.1, 60.0
    dev, clock = device({"creep": {"strength": s, "time_constant_s": tau, "stretch": 0.5}})
    truth = dev.true_model()
    out = at(dev, clock, [(4.0, 100.0), (2.0, 30.0), (3.0, 50.0)])
    # no reversal before the first turn: equation (22)
    assert out[0] == pytest.approx(truth.predict(np.array([4.0]))[0], abs=1e-12)
    # the input turned back at t = 100 s after an excursion of 4 V (from 0 V)
    first = 4.0 * math.exp(-math.sqrt(30.0 / tau))
    assert out[1] - truth.predict(np.array([4.0, 2.0]))[1] == pytest.approx(s * first, rel=1e-9)
    # at t = 130 s it turned again after an excursion of -2 V; read at 180 s
    both = 4.0 * math.exp(-math.sqrt(80.0 / tau)) - 2.0 * math.exp(-math.sqrt(50.0 / tau))
    assert out[2] - truth.predict(np.array([4.0, 2.0, 3.0]))[2] == pytest.approx(s * both, rel=1e-9)


def test_sensor_nonlinearity_saturates_the_psd_reading():
    dev, clock = device({"sensor_nonlinearity": {"strength": 0.3, "centre_V": 0.5}})
    dev.apply_voltage(5.0)
    clock.sleep(30.0)
    linear = dev.deflection_um() / dev.params.psd_um_per_V
    assert dev.read_psd() == pytest.approx(0.5 + math.tanh((linear - 0.5) * 0.3) / 0.3, rel=1e-12)
    assert abs(dev.read_psd() - 0.5) < abs(linear - 0.5)
