"""Inversion of the Preisach model (identify/inverse): exact roots, the choice rule, unreachable targets,
the memory advanced as the forward model does, the effects, and the feedback laws."""

import dataclasses
import math

import numpy as np
import pytest

from identify import Grid, IdentifyError, PreisachModel
from identify.effects import EFFECTS, pipeline_order
from identify.inverse import (ILC, PI, Inverter, LinearInverse, NoFeedback, NotInvertible, invert, make_feedback,
                              output_range, period_of)
from identify.inverse.effects import LagState
from identify.inverse.path import PreisachPath
from identify.inverse.roots import closest_to_zero, roots_between
from identify.memory import MemoryCurve
from identify.runs import Run


def random_model(levels, seed, mu0=2.0, c_d=-1.5, v_max=6.0):
    rng = np.random.default_rng(seed)
    g = Grid(levels, 0.0, v_max)
    return PreisachModel(g, rng.uniform(0.0, 1.0, g.n_cells) * 30.0 / g.n_cells, mu0, c_d)


def one_cell(c_d=-1.0):
    """L = 1 on [0, 1] V, one (triangular) cell of weight 1 um: rising from 0 V the output is
    ``u(v) = c_d v + 2 v^2 - 1`` (the switched-up fraction of a triangle is ``v^2``)."""
    return PreisachModel(Grid(1, 0.0, 1.0), np.array([1.0]), 0.0, c_d)


# ---------------------------------------------------------------- the pieces
@pytest.mark.parametrize("levels", [1, 2, 5, 17])
def test_the_pieces_of_a_move_give_the_forward_models_output_everywhere(levels):
    m = random_model(levels, levels, mu0=0.0, c_d=0.0)
    g = m.grid
    rng = np.random.default_rng(1)
    for _ in range(60):
        history = rng.uniform(-0.5, 6.5, rng.integers(0, 9))
        state = m.state(history=history if history.size else None)
        path = PreisachPath(g, m.density, state.curve)
        assert path.value == pytest.approx(state.output, abs=1e-12)
        x = float(rng.uniform(0, levels))
        *_, (s, e, cell, p0, p1, p2) = path.pieces(x > path.position, x)
        f = x - cell
        assert p0 + p1 * f + p2 * f * f == pytest.approx(state.peek(g.v_min + g.step * x), abs=1e-12)


def test_polynomial_roots_on_an_interval():
    assert roots_between([-2.0, 0.0, 1.0], 0.0, 2.0) == pytest.approx([math.sqrt(2.0)])
    assert roots_between([1.0, -3.0, 2.0], 0.0, 1.0) == pytest.approx([0.5, 1.0])
    assert roots_between([0.5, -3.0, 2.0], 0.0, 1.0) == pytest.approx([(3 - math.sqrt(5)) / 4])
    assert roots_between([1.0, 0.0, 1.0], -5.0, 5.0) == []
    # a quartic: (f - 0.2)(f - 0.7)(f^2 + 1)
    c = np.polynomial.polynomial.polyfromroots([0.2, 0.7])
    quartic = np.polynomial.polynomial.polymul(c, [1.0, 0.0, 1.0])
    assert roots_between(list(quartic), 0.0, 1.0) == pytest.approx([0.2, 0.7])
    assert closest_to_zero([1.0, -1.0, 1.0], 0.0, 1.0) == pytest.approx((0.5, 0.75))


# ---------------------------------------------------------------- exact inversion
@pytest.mark.parametrize("levels,seed", [(1, 0), (3, 1), (8, 2), (30, 3)])
def test_every_target_reachable_from_the_memory_state_is_reached_exactly(levels, seed):
    """Each target is the output some voltage -- up or down, any branch -- would give from the memory the
    inverse has reached: it must be reached, and the forward model on the voltages gives the targets."""
    m = random_model(levels, seed)
    inv = Inverter(m)
    rng = np.random.default_rng(seed)
    voltages, targets = [], []
    for _ in range(120):
        state = m.state(history=np.asarray(voltages) if voltages else None)
        y = state.peek(float(rng.uniform(0.0, 6.0)))
        step = inv.step(y)
        assert step.reachable, (len(voltages), y)
        voltages.append(step.v)
        targets.append(y)
    np.testing.assert_allclose(m.predict(np.asarray(voltages)), targets, rtol=0, atol=1e-10)


def test_a_whole_sequence_in_one_call_matches_the_forward_model():
    m = random_model(30, 7)
    y = np.random.default_rng(0).uniform(-14.0, 10.0, 400)
    r = invert(m, y)
    forward = m.predict(r.voltages)
    np.testing.assert_allclose(forward, r.predicted, rtol=0, atol=1e-10)
    np.testing.assert_allclose(forward[r.reachable], y[r.reachable], rtol=0, atol=1e-10)
    assert r.reachable.mean() > 0.8
    assert np.all(np.abs(forward[~r.reachable] - y[~r.reachable]) > 1e-9)  # never silently "reached"
    np.testing.assert_allclose(r.closest[~r.reachable], forward[~r.reachable], rtol=0, atol=1e-10)


def test_the_choice_rule_takes_the_root_nearest_the_previous_voltage():
    """``u = 2 v^2 - v - 1`` rising from 0 V: -1.1 um is reached at (1 +- sqrt(0.2)) / 4 V; the nearer."""
    inv = Inverter(one_cell())
    s = inv.step(-1.1)
    assert s.reachable and s.v == pytest.approx((1 - math.sqrt(0.2)) / 4, abs=1e-14)
    assert s.predicted == pytest.approx(-1.1, abs=1e-14)


def test_equally_near_roots_go_to_the_least_heater_power():
    """No hysteresis, a reversible term symmetric about 0.5 V (a cubic spline on the walls 0, 0.5, 1 V with
    symmetric B-spline coefficients 0, -1, -1.5, -1, 0): from 0.5 V, its value at 0.3 V is 0.3 V or 0.7 V away alike."""
    rev = EFFECTS["reversible"]({"walls": [0.0, 0.5, 1.0], "increments_um": list(np.diff([0, -1, -1.5, -1, 0]))})
    m = PreisachModel(Grid(2, 0.0, 1.0), np.zeros(3), 0.0, 0.0, effects=(rev,))
    y = float(rev.contribution(Run("probe", np.array([0.3, 0.7]), np.zeros(2), np.zeros(2), np.full(2, np.nan)))[0])
    s = Inverter(m, initial_V=0.5).step(y)
    assert s.reachable and s.v == pytest.approx(0.3, abs=1e-12)
    s = Inverter(m, initial_V=0.55).step(y)  # now 0.7 V is nearer
    assert s.v == pytest.approx(0.7, abs=1e-12)


def test_an_unreachable_target_is_reported_with_the_closest_output_and_the_memory_moves_there():
    inv = Inverter(one_cell())
    s = inv.step(-1.2)  # the output's minimum rising from 0 V is -1.125 um, at 0.25 V
    assert not s.reachable
    assert s.v == pytest.approx(0.25, abs=1e-12)
    assert s.closest == pytest.approx(-1.125, abs=1e-12) and s.predicted == pytest.approx(-1.125, abs=1e-12)
    s = inv.step(-1.0)  # from 0.25 V: up to 0.5 V, or back down to 0 V -- 0 V is 0.25 V away too; least power
    assert s.reachable and s.v == pytest.approx(0.0, abs=1e-12)


def test_set_points_keep_to_the_domain_and_a_domain_beyond_the_grid_is_refused():
    m = random_model(10, 3)
    r = invert(m, np.full(20, 9.0), domain=(0.5, 4.0))
    assert r.voltages.min() >= 0.5 and r.voltages.max() <= 4.0
    with pytest.raises(IdentifyError, match="beyond the model's grid"):
        Inverter(m, domain=(0.0, 7.0))


def test_the_major_loop_bounds_the_output_and_the_linear_inverse_is_its_line():
    m = one_cell(c_d=0.0)  # u = 2 v^2 - 1 up, and back down along the top: range [-1, 1]
    lo, hi = output_range(m)
    assert lo == pytest.approx(-1.0, abs=1e-12) and hi == pytest.approx(1.0, abs=1e-12)
    lin = LinearInverse.of_model(m)
    assert lin.slope_um_per_V > 0
    np.testing.assert_allclose(lin.voltages([lin.intercept_um + 0.5 * lin.slope_um_per_V, 1e9]), [0.5, 1.0])


# ---------------------------------------------------------------- with effects
E = EFFECTS
TIMED_EFFECTS = {
    "joule_power": [E["joule_power"]({"um_per_V2": 0.4, "um_per_V4": -0.006})],
    "reversible": [E["reversible"]({"walls": list(np.linspace(0, 6, 8)),
                                    "increments_um": [0.5, 0.2, 0.8, -0.3, 0.8, 0.1, 0.4, 0.2, 0.1]})],
    "creep reversal": [E["creep"]({"drive": "reversal", "time_constants_s": [2.0, 20.0, 200.0],
                                   "weights": [0.2, 0.3, 0.1]})],
    "creep output": [E["creep"]({"drive": "output", "time_constants_s": [2.0, 20.0], "weights": [0.02, 0.03]})],
    "creep phase": [E["creep"]({"drive": "phase", "time_constants_s": [2.0, 20.0], "weights": [-0.02, 0.03]})],
    "thermal_lag power": [E["thermal_lag"]({"drive": "power", "time_constants_s": [5.0, 60.0],
                                            "fractions": [0.2, 0.1]})],
    "thermal_lag voltage": [E["thermal_lag"]({"drive": "voltage", "time_constants_s": [5.0], "fractions": [0.3]})],
    "thermal_lag both": [E["thermal_lag"]({"drive": "both", "time_constants_s": [5.0, 30.0],
                                           "fractions": [0.2, 0.15]})],
    "thermal_lag lead": [E["thermal_lag"]({"drive": "power", "time_constants_s": [5.0, 60.0],
                                           "fractions": [-0.1, -0.05]})],
    "thermal_lag overshoot": [E["thermal_lag"]({"drive": "both", "time_constants_s": [5.0, 120.0],
                                                "fractions": [0.2, -0.1], "sign": 1, "split_s": 100.0})],
    "interaction": [E["interaction"]({"k": 0.02, "drive": "voltage", "source": "output"})],
    "interaction and lag": [E["interaction"]({"k": -0.03, "drive": "voltage", "source": "output"}),
                            E["thermal_lag"]({"drive": "power", "time_constants_s": [5.0], "fractions": [0.25]})],
    "sensor": [E["sensor_nonlinearity"]({"knots_z": [-1, -0.5, 0, 0.5, 1], "coefficients_um": [0.5, -0.8, 0.4],
                                         "centre_um": -4, "half_range_um": 14})],
    "joule, creep and sensor": [E["joule_power"]({"um_per_V2": 0.4}),
                                E["creep"]({"drive": "reversal", "time_constants_s": [20.0], "weights": [0.3]}),
                                E["sensor_nonlinearity"]({"knots_z": [-1, 0, 1], "coefficients_um": [0.5],
                                                          "centre_um": -4, "half_range_um": 14})],
    "a drift of another run": [E["baseline_drift"]({"runs": {"fit": {
        "knots_s": [0, 0, 0, 0, 100, 100, 100, 100], "coefficients": [0.1, 0.2, 0.3, 0.4]}}})],
}


@pytest.mark.parametrize("case", list(TIMED_EFFECTS))
def test_with_effects_the_forward_model_on_the_voltages_gives_the_targets(case):
    m = dataclasses.replace(random_model(8, 4), effects=tuple(pipeline_order(TIMED_EFFECTS[case])))
    rng = np.random.default_rng(5)
    n = 80
    t = np.cumsum(rng.choice([2.0, 8.0, 30.0], n))
    dwell = np.diff(np.concatenate([[0.0], t]))
    y = np.clip(-4 + 10 * np.sin(np.linspace(0, 12, n)) * np.exp(-np.linspace(0, 1.5, n)) + rng.normal(0, 1, n),
                -15, 8)
    r = invert(m, y, t, dwell)
    forward = m.predict_run(Run("target", r.voltages, np.zeros(n), t, dwell))
    np.testing.assert_allclose(forward, r.predicted, rtol=0, atol=1e-9)
    assert r.reachable.mean() > 0.9
    np.testing.assert_allclose(forward[r.reachable], y[r.reachable], rtol=0, atol=1e-9)


def test_the_lags_closed_form_inverts_its_forward_map():
    for c in [(0.0, 1.0, 0.0, 1.0), (2.0, 0.7, 0.0, 1.0), (0.0, 1.0, 0.3, 0.8), (1.5, 0.8, 0.2, 0.85)]:
        for v in (0.3, 1.0, 2.5, 5.9):
            assert LagState.backward(c, LagState.forward(c, v)) == pytest.approx(v, abs=1e-12)


@pytest.mark.parametrize("effect,why", [
    (E["first_point"]({"coefficients_um": [0.1] * 7, "decay": 0.0, "cell": 0.2}), "saturating exponential"),
    (E["creep"]({"drive": "excursion", "time_constants_s": [2.0], "weights": [0.1]}), "depends on the set-point after"),
    (E["interaction"]({"k": 0.02, "drive": "power", "source": "output"}), "drive 'voltage'"),
])
def test_effects_without_an_exact_inverse_are_refused_saying_why(effect, why):
    m = dataclasses.replace(random_model(4, 0), effects=(effect,))
    with pytest.raises(NotInvertible, match=why):
        Inverter(m)


def test_a_lag_with_a_function_of_the_set_point_is_refused():
    lag = E["thermal_lag"]({"drive": "power", "time_constants_s": [5.0], "fractions": [0.2]})
    joule = E["joule_power"]({"um_per_V2": 0.1})
    m = dataclasses.replace(random_model(4, 0), effects=tuple(pipeline_order([lag, joule])))
    with pytest.raises(NotInvertible, match="thermal_lag together with joule_power"):
        Inverter(m)


def test_a_drift_fitted_on_the_run_being_inverted_is_refused():
    drift = E["baseline_drift"]({"runs": {"track": {"knots_s": [0, 0, 0, 0, 1, 1, 1, 1], "coefficients": [0] * 4}}})
    m = dataclasses.replace(random_model(4, 0), effects=(drift,))
    with pytest.raises(NotInvertible, match="known only after the run"):
        Inverter(m, run_name="track")
    Inverter(m, run_name="another")  # unknown there: it changes nothing


# ---------------------------------------------------------------- feedback
def test_the_period_of_a_repeated_target():
    assert period_of(np.tile([1.0, 3.0, 2.0], 3)) == 3
    assert period_of(np.concatenate([np.tile([1.0, 3.0], 2), [1.0]])) == 2
    assert period_of(np.array([1.0, 2.0, 3.0])) is None
    with pytest.raises(IdentifyError, match="periodic target"):
        make_feedback("ilc", np.array([1.0, 2.0, 3.0]))


def _close_loop(law, targets, plant):
    errors = []
    for k, y in enumerate(targets):
        c = law.command(k, y)
        measured = plant(k, c)
        law.observe(k, y, measured, True)
        errors.append(measured - y)
    return np.asarray(errors)


def test_pi_removes_a_constant_offset_at_the_rate_its_integral_gain_sets():
    """Plant: the inverse reaches the command, the actuator adds 1 um: e_k = -1 - c_k."""
    e = _close_loop(PI(kp=0.0, ki=0.5), np.zeros(12), lambda k, c: c + 1.0)
    np.testing.assert_allclose(e, 0.5 ** np.arange(12), rtol=1e-12)
    assert np.all(_close_loop(NoFeedback(), np.zeros(3), lambda k, c: c + 1.0) == 1.0)


def test_ilc_learns_a_repeating_error_over_the_repetitions():
    offset = np.array([0.4, -0.2, 0.1])  # the model's error, the same at each phase of every repetition
    e = _close_loop(ILC(period=3, gain=0.5), np.zeros(12), lambda k, c: c + offset[k % 3])
    np.testing.assert_allclose(e.reshape(4, 3), offset[None, :] * 0.5 ** np.arange(4)[:, None], rtol=1e-12)


def test_pi_does_not_integrate_while_the_command_is_unreachable():
    law = PI(kp=0.0, ki=0.5)
    law.observe(0, 0.0, -1.0, False)
    assert law.command(1, 0.0) == 0.0
