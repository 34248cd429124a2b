"""The simulated VO2 device: equation (22) at steady state, the thermal lag, noise, faults, effects, state."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate

from drivers import SensorError, VirtualClock, default_config, open_rig
from drivers.sim import DeviceRefused, Effect, SimParams, SimVO2
from drivers.sim.builtin_effects import make_effects
from drivers.sim.transition import transition_density
from identify import Grid, PreisachModel, damped_oscillation, random_input
from identify.model_json import model_from_dict, model_to_dict

QUIET = dict(psd_noise_V=0.0)


def settled_dwell(params: SimParams) -> float:
    return 40.0 * params.time_constant_s


def test_steady_state_reproduces_equation_22_exactly_through_the_rig():
    cfg = default_config(**QUIET)
    clock = VirtualClock()
    with open_rig(cfg, clock=clock) as rig:
        truth = rig.device.true_model()
        grid = truth.grid
        v = np.concatenate([damped_oscillation(grid, thermal_term=True), random_input(grid, 150, seed=3)])
        y = []
        for x in v:
            rig.heater.set_voltage(x)
            rig.clock.sleep(settled_dwell(cfg.sim))
            y.append(rig.sensor.read().deflection_um)
    np.testing.assert_allclose(y, truth.predict(v), rtol=0, atol=1e-12)
    assert clock.now() == pytest.approx(v.size * 20.0)


def test_device_output_is_the_model_when_settled():
    clock = VirtualClock()
    dev = SimVO2(SimParams(levels=12, **QUIET), clock)
    truth = dev.true_model()
    v = random_input(truth.grid, 60, seed=9)
    out = []
    for x in v:
        dev.apply_voltage(x)
        clock.sleep(50.0)
        out.append(dev.deflection_um())
    # equal to rounding: the device sums signed areas cell by cell, predict() Everett terms
    np.testing.assert_allclose(out, truth.predict(v), rtol=0, atol=1e-12)


def test_first_order_thermal_lag_by_hand():
    p = SimParams(time_constant_s=0.5, **QUIET)
    clock = VirtualClock()
    dev = SimVO2(p, clock)
    dev.apply_voltage(5.0)
    target = p.steady_rise_K(5.0)
    assert target == pytest.approx(p.kelvin_per_V2 * 25.0)
    clock.sleep(0.5)  # one time constant
    s = dev.state()
    assert s.rise_K == pytest.approx(target * (1 - math.exp(-1)), rel=1e-12)
    assert s.temperature_C == pytest.approx(25.0 + s.rise_K)
    assert not s.settled
    # The memory curve's input is the equivalent voltage of the current temperature.
    assert s.preisach_input_V == pytest.approx(5.0 * math.sqrt(1 - math.exp(-1)), rel=1e-12)
    clock.sleep(1.0)
    assert dev.state().rise_K == pytest.approx(target * (1 - math.exp(-3)), rel=1e-12)
    clock.sleep(30.0)
    s = dev.state()
    assert s.settled and s.rise_K == target and s.preisach_input_V == 5.0
    # Cooling back: halfway in time constants, from the settled rise.
    dev.apply_voltage(0.0)
    clock.sleep(0.5 * math.log(2))
    assert dev.state().rise_K == pytest.approx(target / 2, rel=1e-12)


def test_a_short_dwell_measures_a_different_memory_state():
    p = SimParams(**QUIET)
    truth = SimVO2(p).true_model()
    v = damped_oscillation(truth.grid)[:40]
    outs = {}
    for dwell in (0.2, settled_dwell(p)):
        clock = VirtualClock()
        dev = SimVO2(p, clock)
        y = []
        for x in v:
            dev.apply_voltage(x)
            clock.sleep(dwell)
            y.append(dev.deflection_um())
        outs[dwell] = np.array(y)
    np.testing.assert_allclose(outs[settled_dwell(p)], truth.predict(v), rtol=0, atol=1e-12)
    assert np.max(np.abs(outs[0.2] - truth.predict(v))) > 1.0


def test_default_physics_is_plausible():
    p = SimParams()
    assert p.ambient_C + p.steady_rise_K(p.v_max_V) == pytest.approx(110.25, abs=0.1)
    # The paper's 12.78 mA at the DAQ's 10 V full scale.
    assert p.max_output_V / p.total_resistance_ohm * 1e3 == pytest.approx(12.78, rel=1e-3)
    assert p.voltage_at(p.transition_heating_C) == pytest.approx(4.26, abs=0.01)
    assert p.steady_rise_K(p.voltage_at(80.0)) == pytest.approx(55.0)


def test_transition_density_is_the_exact_cell_mass():
    p = SimParams(levels=10, transition_width_C=8.0)
    grid = Grid(10, 0.0, 6.0)
    d = transition_density(grid, p)
    assert d.sum() == pytest.approx(p.transition_amplitude_um)
    assert np.all(d >= 0)

    def temp(v):
        return p.ambient_C + p.kelvin_per_V2 * v * v

    def pdf(t, centre):
        s = p.transition_width_C
        return math.exp(-0.5 * ((t - centre) / s) ** 2) / (s * math.sqrt(2 * math.pi))

    def mass(i, j):
        lo_a, hi_a = temp(grid.walls[i]), temp(grid.walls[i + 1])
        lo_b, hi_b = temp(grid.walls[j]), temp(grid.walls[j + 1])
        val, _ = integrate.dblquad(
            lambda tb, ta: pdf(ta, p.transition_heating_C) * pdf(tb, p.transition_cooling_C),
            lo_a, hi_a, lo_b, lambda ta: min(ta, hi_b), epsabs=1e-13,
        )
        return val

    square, diag = grid.cell_index(7, 6), grid.cell_index(7, 7)
    assert d[diag] / d[square] == pytest.approx(mass(7, 7) / mass(7, 6), rel=1e-9)


def test_noise_is_seeded_and_has_the_configured_rms():
    readings = []
    for seed in (4, 4, 5):
        dev = SimVO2(SimParams(seed=seed, time_constant_s=0.0))
        readings.append(np.array([dev.read_psd() for _ in range(2000)]))
    assert np.array_equal(readings[0], readings[1])
    assert not np.array_equal(readings[0], readings[2])
    assert np.std(readings[0]) == pytest.approx(0.002, rel=0.1)
    quiet = SimVO2(SimParams(**QUIET))
    assert quiet.read_psd() == pytest.approx(-13.0 / 5.0)  # mu0 - amplitude at rest, 5 um/V


def test_refused_setpoints_leave_the_device_unchanged():
    dev = SimVO2(SimParams())
    dev.apply_voltage(1.0)
    for bad in (math.nan, math.inf, 10.5, -11.0, "2"):
        with pytest.raises(DeviceRefused):
            dev.apply_voltage(bad)
    assert dev.applied_voltage == 1.0
    assert [v for _, v in dev.setpoints] == [1.0]


def test_faults_and_rails_reach_the_sensor_which_retries_or_fails_clearly():
    with open_rig(default_config(**QUIET)) as rig:
        rig.device.faults.nan_readings = 2
        assert math.isfinite(rig.sensor.read().deflection_um)  # third attempt
        assert rig.device.faults.nan_readings == 0
        rig.device.faults.saturated_readings = 3
        with pytest.raises(SensorError, match="saturated"):
            rig.sensor.read()
    with open_rig(default_config(transition_amplitude_um=80.0)) as rig:
        with pytest.raises(SensorError, match="saturated"):  # -78 um / 5 um/V: beyond the -10 V rail
            rig.sensor.read()
    assert rig.device.applied_voltage == 0.0


def test_resaturating_and_replaying_restores_the_memory_state():
    """What resuming a crashed run relies on: saturate, replay quickly, same state."""
    p = SimParams(**QUIET)
    history = random_input(Grid(30, 0.0, 6.0), 40, seed=11)

    def run(dev, clock, inputs, dwell):
        for x in inputs:
            dev.apply_voltage(x)
            clock.sleep(dwell)

    ca, cb = VirtualClock(), VirtualClock()
    a, b = SimVO2(p, ca), SimVO2(p, cb)
    run(a, ca, history, 60.0)
    run(b, cb, random_input(Grid(30, 0.0, 6.0), 25, seed=12), 60.0)  # some other past
    assert a.state().memory != b.state().memory
    run(b, cb, [p.v_max_V, p.v_min_V], settled_dwell(p))  # saturate
    assert b.state().memory == SimVO2(p).state().memory
    run(b, cb, history, settled_dwell(p))  # replay quickly
    sa, sb = a.state(), b.state()
    assert sa.memory == sb.memory
    np.testing.assert_array_equal(sa.signed_areas, sb.signed_areas)
    assert sa.deflection_um == sb.deflection_um and sa.temperature_C == sb.temperature_C


def test_true_model_round_trips_through_json():
    model = SimVO2(SimParams(levels=6)).true_model()
    again = model_from_dict(json.loads(json.dumps(model_to_dict(model))))
    np.testing.assert_array_equal(again.density, model.density)
    assert (again.mu0, again.c_d) == (2.0, -1.5)
    assert again.metadata["params"]["time_constant_s"] == 0.5


# ------------------------------------------------------------ the effects hook


class InputShift(Effect):
    name = "input_shift"
    parameters = {"volts": 0.25}

    def preisach_input(self, volts, moment):
        return volts + self.strength * self.volts


class Offsets(Effect):
    name = "offsets"

    def reset(self):
        self.events = []
        self.rises = 0

    def on_setpoint(self, t_s, old_V, new_V):
        self.events.append((t_s, old_V, new_V))

    def temperature_rise(self, rise_K, moment):
        self.rises += 1
        return rise_K

    def deflection(self, um, moment):
        return um + self.strength

    def psd(self, volts, moment):
        return volts * 2.0

    def state(self):
        return {"events": len(self.events)}


def test_effects_act_at_their_stage_of_the_pipeline():
    p = SimParams(levels=10, **QUIET)
    registry = {"input_shift": InputShift, "offsets": Offsets}
    effects = make_effects({"input_shift": {"strength": 2.0, "volts": 0.15}, "offsets": 0.5}, registry)
    clock = VirtualClock()
    dev = SimVO2(p, clock, effects=effects)
    truth = dev.true_model()
    phase_only = PreisachModel(truth.grid, truth.density)
    v = random_input(truth.grid, 30, seed=2)
    defl, psd = [], []
    for x in v:
        dev.apply_voltage(x)
        clock.sleep(20.0)
        defl.append(dev.deflection_um())
        psd.append(dev.read_psd())
    # ambient-drift-like shift of the Preisach input by 2 x 0.15 V; thermal term on the unshifted v.
    expected = phase_only.predict(v + 0.3) + p.bias_um + p.thermal_um_per_V * v + 0.5
    np.testing.assert_allclose(defl, expected, atol=1e-12)
    np.testing.assert_allclose(psd, 2.0 * expected / p.psd_um_per_V, atol=1e-12)
    assert dev.state().effects == {"input_shift": {"strength": 2.0}, "offsets": {"events": 30}}
    assert effects[1].events[1] == (20.0, v[0], v[1])


def test_effects_can_ask_for_smaller_steps():
    class Stepped(Offsets):
        max_step_s = 0.25

    stepped = Stepped(0.0)
    clock = VirtualClock()
    dev = SimVO2(SimParams(), clock, effects=[stepped])
    before = stepped.rises
    clock.sleep(10.0)
    dev.read_psd()
    assert stepped.rises - before == 40


def test_effect_table_validation():
    registry = {"offsets": Offsets}
    assert make_effects({"offsets": 0.0}, registry) == []  # zero strength: off
    with pytest.raises(ValueError, match="unknown key 'sim.effects.offsets.gain'"):
        make_effects({"offsets": {"strength": 1.0, "gain": 2.0}}, registry)
    with pytest.raises(ValueError, match="missing key 'sim.effects.offsets.strength'"):
        make_effects({"offsets": {}}, registry)
    with pytest.raises(ValueError, match="unknown effect 'sim.effects.creep'"):
        make_effects({"creep": 0.1}, registry)
    with pytest.raises(ValueError, match="finite number"):
        make_effects({"offsets": "strong"}, registry)
