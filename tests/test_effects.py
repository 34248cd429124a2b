"""Effects as model terms (identify.effects): exact recovery, prediction, storage and the command line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from identify import Grid, IdentifyError, PreisachModel
from identify.effects import EFFECTS, EffectNotApplicable, EffectNotIdentifiable, make_effect, parse_effects
from identify.effects.bases import splines_at, time_knots
from identify.effects.compose import deflection, predict_run
from identify.effects.joint import fit_with_effects
from identify.forward import HysteresisState
from identify.runs import Run
from identify.validation import validate_run
from sessions import ModelRecord, add_model, read_session

from .cli import assert_one_line_error, rig_here as rig
from .conftest import digest

GRID = Grid(6, 0.0, 4.0)


def _design(n=420, seed=1):
    """A random input with reversals, off the walls, with varied dwells (s) and time stamps."""
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(0.0, 0.7, n)) % 8.0
    v = np.where(walk > 4.0, 8.0 - walk, walk)
    dwell = rng.choice([5.0, 10.0, 30.0, 60.0], n)
    return v, dwell, np.cumsum(dwell)


V, DWELL, T = _design()
TRUE = PreisachModel(GRID, np.random.default_rng(7).uniform(0.1, 1.0, GRID.n_cells), mu0=0.3, c_d=-0.4)


def run_of(y, v=V, dwell=DWELL, t=T, name="sim"):
    return Run(name, v, y, t, dwell, 4, 0.0)


def _drift_params():
    """A drift the fit's roughness penalty leaves alone (a straight line in time, as B-spline coefficients at
    the Greville abscissae) with a slow bump that it does not."""
    knots = time_knots(run_of(np.ones(V.size)))
    greville = np.array([knots[j + 1:j + 4].mean() for j in range(knots.size - 4)])
    coef = 0.02 + 0.08 * (greville - greville[0]) / np.ptp(greville)
    return {"runs": {"sim": {"knots_s": knots.tolist(), "coefficients": coef.tolist()}}}


from identify.effects.creep import TIME_CONSTANTS_S as CREEP_TAUS  # noqa: E402
from identify.effects.thermal_lag import TIME_CONSTANTS_S as LAG_TAUS  # noqa: E402
from identify.model_json import model_from_dict, model_to_dict

TRUTHS = {
    "thermal_lag": {"drive": "power", "time_constants_s": list(LAG_TAUS),
                    "fractions": [0.1 if j == 3 else 0.15 if j == 5 else 0.0 for j in range(len(LAG_TAUS))]},
    "baseline_drift": None,
    "ambient_drift": None,
    "gain_drift": None,
    "joule_power": {"um_per_V2": 0.07, "um_per_V4": -0.002},
    # a spectrum the fit's (weak) roughness penalty leaves alone: straight over log tau
    "creep": {"drive": "reversal", "time_constants_s": list(CREEP_TAUS),
              "weights": list(0.002 + 0.004 * np.arange(len(CREEP_TAUS)))},
    "sensor_nonlinearity": {"knots_z": [-1.0, -0.5, 0.0, 0.5, 1.0], "coefficients_um": [0.3, -0.5, 0.2],
                            "centre_um": 0.0, "half_range_um": 3.0},
    "reversible": {"walls": GRID.walls.tolist(),
                   "increments_um": (0.2 * np.sin(np.arange(GRID.levels + 2))).tolist()},
    "interaction": {"k": 0.02, "drive": "voltage"},
    "first_point": {"coefficients_um": [0.01, 0.02, -0.005, 0.03, -0.01, 0.004, 0.02, 0.006, -0.015, 0.012],
                    "decay": 0.6,
                    "cell": GRID.step},
}


def _truth(name):
    params = TRUTHS[name] if TRUTHS[name] is not None else _drift_params()
    if name in ("ambient_drift", "gain_drift"):  # the first run's mean is the density's reference (room; scale)
        entry = params["runs"]["sim"]
        c = np.asarray(entry["coefficients"])
        c = c - splines_at(np.asarray(entry["knots_s"]), T).mean(axis=0) @ c
        params = {"runs": {"sim": {**entry, "coefficients": c.tolist()}}}
    model = replace(TRUE, effects=(EFFECTS[name](params),))
    if name == "reversible":
        model = replace(model, c_d=0.0)
    y = predict_run(model, run_of(np.zeros(V.size)))
    if name == "sensor_nonlinearity":  # the fit scales the map by the outputs it sees: make the truth's the same
        for _ in range(60):
            params = {**params, "centre_um": 0.5 * (y.max() + y.min()), "half_range_um": 0.5 * np.ptp(y)}
            model = replace(TRUE, effects=(EFFECTS[name](params),))
            y = predict_run(model, run_of(np.zeros(V.size)))
    if name == "baseline_drift":  # the first run's drift has zero mean: the constant is mu0's
        entry = params["runs"]["sim"]
        b = splines_at(np.asarray(entry["knots_s"]), T)
        c = np.asarray(entry["coefficients"])
        shift = float(b.mean(axis=0) @ c)
        params = {"runs": {"sim": {**entry, "coefficients": (c - shift).tolist()}}}
        model = replace(TRUE, mu0=TRUE.mu0 + shift, effects=(EFFECTS[name](params),))
    return model, params, y


@pytest.mark.parametrize("name", list(EFFECTS))
def test_each_effect_recovers_its_own_parameters_exactly_from_noise_free_data(name, monkeypatch):
    # a roughness penalty is a prior that biases what it penalises: exactness is checked without it
    import identify.effects.reversible as reversible

    monkeypatch.setattr(reversible, "FIT_SMOOTHING", 0.0)
    truth, params, y = _truth(name)
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect(name)])
    scale = float(np.ptp(y))
    assert fit.rmse <= 1e-9 * scale
    got = fit.model.effects[0].params
    for key, value in params.items():
        if isinstance(value, str):
            assert got[key] == value
        elif key == "runs":
            for run, entry in value.items():
                got_c = np.asarray(got["runs"][run]["coefficients"])
                np.testing.assert_allclose(got_c, entry["coefficients"], atol=1e-7 * max(1.0, np.abs(got_c).max()))
        else:
            np.testing.assert_allclose(np.asarray(got[key], float), np.asarray(value, float), rtol=1e-6, atol=1e-8)
    if name != "interaction":  # with feedback some cells can switch together and share their weight
        np.testing.assert_allclose(fit.model.density, truth.density, atol=1e-7)
    assert fit.model.mu0 == pytest.approx(truth.mu0, abs=1e-7)
    assert fit.model.c_d == pytest.approx(truth.c_d, abs=1e-7)


@pytest.mark.parametrize("drive", ["voltage", "power"])
def test_a_memo_resumes_the_fixed_point_where_runs_part_with_the_same_numbers(drive):
    # a discriminating design predicts one plan with each candidate segment appended: the memo solves only
    # from where a run parts from the one solved before, and every number is a solve from the start's
    from identify.effects.compose import FixedPointMemo

    k = 0.05 if drive == "voltage" else 0.2
    model = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "drive": drive}),))
    other = replace(model, density=model.density[::-1].copy())  # another model: never served this one's runs
    memo = FixedPointMemo()
    prefix = 300
    runs = [run_of(np.zeros(V.size))]
    for seed in (2, 3):  # the same beginning, other segments after it
        w, d, _ = _design(V.size - prefix, seed)
        v = np.concatenate([V[:prefix], w])
        dw = np.concatenate([DWELL[:prefix], d])
        runs.append(run_of(np.zeros(v.size), v, dw, np.cumsum(dw)))
    runs.append(run_of(np.zeros(120), V[:120], DWELL[:120], T[:120]))  # a run that is a beginning of the first
    runs.append(run_of(np.zeros(V.size), V[::-1].copy(), DWELL, T))  # one that parts at once
    for run in runs:
        for m in (model, other):
            np.testing.assert_array_equal(predict_run(m, run, memo=memo), predict_run(m, run))
    # and the design's memo is what it says: resumed beginnings (the second run parts from the first at 300)
    a = np.arange(5.0)
    memo2 = FixedPointMemo()
    memo2.keep(model, a, a, k, drive, a, [(None, 0.0, 0.0)] * 6)
    assert memo2.start(model, np.r_[a[:3], 9.0], np.r_[a[:3], 9.0], k, drive)[0] == 3
    assert memo2.start(model, a[:2], a[:2], k, drive)[0] == 2
    assert memo2.start(other, a, a, k, drive) is None
    assert memo2.start(model, a, a, 2 * k, drive) is None


@pytest.mark.parametrize("drive", ["voltage", "power"])
def test_the_mean_field_fixed_point_is_exact_and_continuous_by_hand(drive):
    k = 0.05 if drive == "voltage" else 0.2  # V/um, V^2/um: about the same shift
    model = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "drive": drive}),))
    run = run_of(np.zeros(V.size))
    u = deflection(model, run)
    # self-consistent: the hysterons' input x = v + k u (x^2 = v^2 + k u) gives u back through the memory curve
    np.testing.assert_allclose(deflection(model, run, feedback=u), u, atol=1e-10)
    # and it is the state a quasi-static sweep reaches: sweep the input in tiny steps, solving by iteration
    bare = replace(TRUE, mu0=0.0, c_d=0.0)
    state = HysteresisState(bare)
    x = GRID.v_min
    for n, v in enumerate(V[:40]):
        prev = V[n - 1] if n else 0.0
        for s in np.linspace(prev, v, 400)[1:]:
            for _ in range(200):  # contraction: |k P'| < 1 here
                b = TRUE.mu0 + TRUE.c_d * s
                target = s + k * (b + state.peek(x)) if drive == "voltage" else s * s + k * (b + state.peek(x))
                x_new = target if drive == "voltage" else math.sqrt(max(target, 0.0))
                if abs(x_new - x) < 1e-13:
                    break
                x = x_new
            state.apply(x)
        assert u[n] == pytest.approx(TRUE.mu0 + TRUE.c_d * v + state.output, abs=1e-6)


@pytest.mark.parametrize("reference", ["insulating", "metallic"])
def test_a_mean_field_counted_from_a_saturated_state_is_the_middles_on_a_shifted_input_by_hand(reference):
    # x = v + k (P - P_ref) = (v - k P_ref) + k P: the phase part is the middle-referenced field's on the
    # input shifted by -k P_ref, and only the thermal term (which sees v) tells the two runs apart
    k, total = 0.05, float(np.sum(TRUE.density))
    p_ref = -total if reference == "insulating" else total
    run = run_of(np.zeros(V.size))
    ref = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "source": "phase", "reference": reference,
                                                         "reference_um": p_ref}),))
    mid = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "source": "phase"}),))
    u = deflection(ref, run)
    np.testing.assert_allclose(deflection(ref, run, feedback=u), u, atol=1e-10)  # self-consistent
    shifted = run_of(np.zeros(V.size), v=V - k * p_ref)
    np.testing.assert_allclose(u, deflection(mid, shifted) + TRUE.c_d * k * p_ref, atol=1e-9)
    assert np.max(np.abs(u - deflection(mid, run))) > 0.05  # the reference matters here


@pytest.mark.parametrize("reference", ["insulating", "metallic"])
def test_a_mean_field_from_a_saturated_state_is_recovered_exactly(reference):
    # k P_ref shifts the input by a tenth of a cell here; at a third (k = 0.02) the fit's starts fall short
    total = float(np.sum(TRUE.density))
    params = {"k": 0.005, "drive": "voltage", "source": "phase", "reference": reference,
              "reference_um": -total if reference == "insulating" else total}
    y = predict_run(replace(TRUE, effects=(EFFECTS["interaction"](params),)), run_of(np.zeros(V.size)))
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("interaction")])
    assert fit.rmse <= 1e-9 * float(np.ptp(y))
    got = fit.model.effects[0].params
    assert (got["source"], got["reference"]) == ("phase", reference)
    assert got["k"] == pytest.approx(0.005, rel=1e-6)
    assert got["reference_um"] == pytest.approx(params["reference_um"], rel=1e-6)


def test_creep_counts_the_rise_from_the_initial_state_into_the_first_point_by_hand():
    # every run starts in negative saturation at initial_V (the sequencer saturates at 0 V); the first
    # set-point is a change of the output like any other, and a slow creep still relaxes from it later
    tau, w = 200.0, 0.01
    creep = EFFECTS["creep"]({"drive": "output", "time_constants_s": [tau], "weights": [w]})
    model = replace(TRUE, effects=(creep,))
    v, t = np.array([3.0, 3.0, 3.0]), np.array([10.0, 110.0, 410.0])
    run = Run("two", v, np.zeros(3), t, np.array([10.0, 100.0, 300.0]), 4, 0.0)
    u = TRUE.predict(v)
    u0 = float(TRUE.predict(np.array([0.0]))[0])  # negative saturation at 0 V
    assert abs(u[0] - u0) > 1.0  # a large rise
    expected = u + w * (u[0] - u0) * np.exp(-t / tau)  # the set-point was applied at t = 0
    np.testing.assert_allclose(predict_run(model, run), expected, rtol=1e-12, atol=1e-12)
    # the joint fit's columns count it the same way: a spectrum its penalty leaves alone is recovered exactly
    smooth = EFFECTS["creep"]({"drive": "output", "time_constants_s": list(CREEP_TAUS),
                               "weights": list(0.002 + 0.001 * np.arange(len(CREEP_TAUS)))})
    y = predict_run(replace(TRUE, effects=(smooth,)), run_of(np.zeros(V.size)))
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("creep")])
    assert fit.rmse <= 1e-9 * float(np.ptp(y))
    np.testing.assert_allclose(fit.model.effects[0].params["weights"], smooth.params["weights"], rtol=1e-6)


def test_a_two_branch_creep_lags_then_relaxes_back_and_is_recovered_exactly():
    # fast relaxations of one sign, slow ones of the other: a creep that lags and then comes back
    from identify.effects.creep import SPLITS, _signs

    assert _signs({"sign": 1.0}, 4).tolist() == [1.0, 1.0, 1.0, 1.0]
    assert _signs({"sign": -1.0, "split": 1}, 4).tolist() == [-1.0, 1.0, 1.0, 1.0]
    assert _signs({"sign": 1.0, "split": 3}, 4).tolist() == [1.0, 1.0, 1.0, -1.0]
    split = next(k for k in SPLITS if k is not None)
    magnitude = 0.002 + 0.002 * np.arange(len(CREEP_TAUS))  # straight over log tau: the penalty leaves it alone
    weights = np.where(np.arange(len(CREEP_TAUS)) < split, magnitude, -magnitude)
    truth = EFFECTS["creep"]({"drive": "output", "time_constants_s": list(CREEP_TAUS), "weights": weights.tolist()})
    y = predict_run(replace(TRUE, effects=(truth,)), run_of(np.zeros(V.size)))
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("creep")])
    assert fit.settings["creep"].get("split") == split
    assert fit.rmse <= 1e-9 * float(np.ptp(y))
    np.testing.assert_allclose(fit.model.effects[0].params["weights"], weights, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("sign, split_index", [(-1.0, None), (1.0, 8)])
def test_a_lag_that_leads_or_overshoots_is_recovered_exactly(sign, split_index):
    # a lead (a heater whose resistance rises: a step's power arrives first and sags) and a beam that lags on a
    # fast mode and gives part of the rise back on a slow one (an overshoot): the fractions' signs are a setting
    from identify.effects.thermal_lag import SPLITS_S, TIME_CONSTANTS_S, signs_of

    split_s = None if split_index is None else TIME_CONSTANTS_S[split_index]
    assert split_s in SPLITS_S
    setting = {"sign": sign, "split_s": split_s}
    signs = signs_of(setting, np.asarray(TIME_CONSTANTS_S))
    assert signs.tolist() == ([-1.0] * 12 if split_index is None else [1.0] * 8 + [-1.0] * 4)
    sizes = [0.1 if j == 4 else 0.08 if j == 9 else 0.0 for j in range(len(TIME_CONSTANTS_S))]
    fractions = (signs * sizes).tolist()
    truth = EFFECTS["thermal_lag"]({"drive": "power", "time_constants_s": list(TIME_CONSTANTS_S),
                                    "fractions": fractions, **setting})
    y = predict_run(replace(TRUE, effects=(truth,)), run_of(np.zeros(V.size)))
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("thermal_lag")])
    assert fit.settings["thermal_lag"]["drive"] == "power"
    assert fit.settings["thermal_lag"]["sign"] == sign
    assert fit.settings["thermal_lag"].get("split_s") == split_s
    assert fit.rmse <= 1e-9 * float(np.ptp(y))
    np.testing.assert_allclose(fit.model.effects[0].params["fractions"], fractions, rtol=1e-6, atol=1e-9)
    # the signs travel with the model: a stored model predicts the same run
    back = model_from_dict(json.loads(json.dumps(model_to_dict(fit.model))))
    assert back.effects[0].params["sign"] == sign and back.effects[0].params["split_s"] == split_s
    np.testing.assert_allclose(predict_run(back, run_of(y)), predict_run(fit.model, run_of(y)), rtol=0, atol=1e-12)


def test_a_lag_written_by_hand_takes_the_signs_of_its_fractions():
    lead = EFFECTS["thermal_lag"]({"time_constant_s": 30.0, "fraction": -0.05})
    assert lead.params["sign"] == -1.0 and lead.params["split_s"] is None
    assert EFFECTS["thermal_lag"]({"time_constant_s": 30.0, "fraction": 0.05}).params["sign"] == 1.0
    with pytest.raises(IdentifyError, match="sign must be 1 or -1"):
        EFFECTS["thermal_lag"]({"time_constants_s": [30.0], "fractions": [0.1], "sign": 0.5})
    with pytest.raises(IdentifyError, match="split_s"):
        EFFECTS["thermal_lag"]({"time_constants_s": [30.0], "fractions": [0.1], "split_s": -3})


def test_an_excursion_creep_turns_with_the_output_that_drives_it_by_hand():
    from identify.effects.creep import excursion_steps

    # while the heater only rises, the output can turn back (a thermal term of the other sign): here it
    # turns twice, and the excursion restarts where it turned, at 3 and at 2 -- the input plays no part
    u = np.array([1.0, 2.0, 3.0, 2.5, 2.0, 2.2])
    excursion = np.array([1.0, 2.0, 3.0, -0.5, -1.0, 0.2])  # from u0 = 0, then from 3, then from 2
    np.testing.assert_allclose(excursion_steps(u, 0.0), np.diff(excursion, prepend=0.0))
    # a change too small to be a move does not turn it
    u2 = np.array([1.0, 2.0, 2.0 - 1e-13, 3.0, 3.0, 4.0])
    np.testing.assert_allclose(excursion_steps(u2, 0.0), np.diff(u2, prepend=0.0), atol=1e-12)


def test_ambient_drift_columns_follow_the_room_at_each_moment_of_the_history():
    # the memory's past extrema were reached at the room temperature of their moment: the columns are the
    # output's change per spline coefficient with the input moved only where each spline lives, so on a
    # small drift they predict its exact effect (a uniform shift of the whole history missed it by 37 %)
    from identify.effects import Context
    from identify.effects.ambient_drift import moved_input

    v = 1.0 + 0.75 * V  # off zero volts, where sqrt(v^2 + d) has no slope to linearise
    run = run_of(np.zeros(v.size), v=v)
    cols = EFFECTS["ambient_drift"]().columns(Context.of_model(TRUE, [run]), {"form": "shift", "smoothing": 0.0})
    splines = splines_at(time_knots(run), T)
    splines = splines - splines[run.rows].mean(axis=0)  # the first run's drift has zero mean
    c = 1e-3 * np.random.default_rng(0).normal(size=splines.shape[1])
    x = moved_input(v, splines @ c, "shift")
    exact = TRUE.predict(x) + TRUE.c_d * (v - x) - TRUE.predict(v)  # the thermal term follows the heater
    assert np.sqrt(np.mean((cols.values[0] @ c - exact) ** 2)) <= 1e-3 * np.sqrt(np.mean(exact**2))


@pytest.mark.parametrize("k", [-1e-3, 1e-3])
def test_the_diagnosis_linearises_an_interaction_of_either_sign_in_its_own_direction(k):
    # the output is not differentiable in k at k = 0 where the input sits on the grid's ends: at the top
    # wall a pull downwards (k < 0 on a high output) unswitches cells, a push upwards changes nothing.  Each
    # direction has its own column, so a weak coupling of either sign is its column times |k|
    from identify.effects import Context

    model = replace(TRUE, effects=(EFFECTS["interaction"]({"k": k, "drive": "voltage", "source": "phase"}),))
    # on the walls and well inside (near a wall, a finite k can carry the input across it: not linear)
    v = np.array([4.0, 1.0, 4.0, 0.0, 3.0, 0.5, 4.0, 2.0, 3.0, 1.5, 3.5, 2.5, 0.0, 2.8, 1.2, 3.9, 0.3, 4.0, 0.0])
    t = np.cumsum(np.full(v.size, 10.0))
    run = Run("ends", v, np.zeros(v.size), t, np.full(v.size, 10.0), 4, 0.0)
    y = predict_run(model, run)
    run = replace(run, outputs=y)
    exact = y - TRUE.predict(v)
    cand = make_effect("interaction")
    col = cand.columns(Context.of_model(TRUE, [run]), {"drive": "voltage", "source": "phase", "sign": np.sign(k)})
    assert col.nonneg == (True,)
    np.testing.assert_allclose(col.values[0][:, 0] * abs(k), exact, atol=0.02 * np.abs(exact).max())


def test_a_model_without_effects_reads_and_writes_as_before():
    d = model_to_dict(TRUE)
    assert "effects" not in d
    back = model_from_dict(json.loads(json.dumps(d)))
    assert back.effects == () and model_to_dict(back) == d


def test_effects_round_trip_through_json_and_a_stored_model(tmp_path):
    truth, _, y = _truth("creep")
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("creep"), make_effect("first_point")])
    again = model_from_dict(json.loads(json.dumps(model_to_dict(fit.model))))
    run = run_of(y)
    np.testing.assert_array_equal(again.predict_run(run), fit.model.predict_run(run))
    assert [e["name"] for e in model_to_dict(fit.model)["effects"]] == ["creep", "first_point"]


def test_bad_effect_names_and_effects_a_run_cannot_identify_are_refused():
    with pytest.raises(IdentifyError, match="known effects are thermal_lag"):
        make_effect("creeep")
    with pytest.raises(IdentifyError, match="given twice"):
        parse_effects("creep,creep")
    with pytest.raises(IdentifyError, match="options monotone"):
        make_effect("reversible:smooth")
    on_walls = GRID.walls[[0, 3, 6, 2, 5, 1, 4]]
    wall_run = Run("w", on_walls, np.ones(7), np.arange(7.0), np.full(7, 10.0))
    with pytest.raises(EffectNotIdentifiable, match="every measured input sits on a wall"):
        fit_with_effects(GRID, [wall_run], "ls", [make_effect("reversible")])
    rising = Run("r", np.linspace(0.1, 3.9, 20), np.ones(20), np.arange(20.0), np.full(20, 10.0))
    with pytest.raises(EffectNotIdentifiable, match="never turns back"):
        fit_with_effects(GRID, [rising], "ls", [make_effect("interaction")])
    same = Run("s", V, np.ones(V.size), T, np.full(V.size, 20.0))
    with pytest.raises(EffectNotIdentifiable, match="same dwell"):
        fit_with_effects(GRID, [same], "ls", [make_effect("thermal_lag")])
    # dwells read from time stamps: 20 s with a logger's jitter (under 5 %) and a first point of its own
    jitter = 20.0 + 0.4 * np.random.default_rng(3).random(V.size)
    jitter[0] = 35.0
    stamped = Run("j", V, np.ones(V.size), np.cumsum(jitter), jitter)
    with pytest.raises(EffectNotIdentifiable, match="every measured point but 1 has the same dwell"):
        fit_with_effects(GRID, [stamped], "ls", [make_effect("thermal_lag")])
    lag = make_effect("thermal_lag")
    few, enough = jitter.copy(), jitter.copy()
    few[1:4], enough[1:5] = 40.0, 40.0  # 4 and 5 points off the common dwell (the first among them)
    assert "same dwell" in lag.identifiable((Run("f", V, np.ones(V.size), np.cumsum(few), few),), GRID)
    assert lag.identifiable((Run("e", V, np.ones(V.size), np.cumsum(enough), enough),), GRID) is None
    # a model with creep cannot act on a run without time stamps
    truth, _, _ = _truth("creep")
    untimed = Run("u", V, np.ones(V.size), np.zeros(V.size), np.full(V.size, np.nan))
    with pytest.raises(EffectNotApplicable, match="record\\(s\\) no time"):
        truth.predict_run(untimed)


def test_a_drift_of_another_run_is_re_estimated_held_out_when_validating():
    truth, params, y = _truth("baseline_drift")
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("baseline_drift")])
    # another run of the same device with its own, different drift
    v2, dwell2, t2 = _design(300, seed=4)
    other = replace(truth, effects=())
    drift = 0.03 * np.sin(t2 / 1500.0)
    y2 = predict_run(other, Run("other", v2, np.zeros(300), t2, dwell2)) + drift
    rep = validate_run(fit.model, Run("other", v2, y2, t2, dwell2), check_range=False)
    assert set(rep.nuisance) == {"baseline_drift"}
    plain = np.sqrt(np.mean((predict_run(other, Run("other", v2, y2, t2, dwell2)) - y2) ** 2))
    assert rep.rmse < 0.2 * plain  # the held-out drift takes most of it away


def _gain_about(pivot_fraction):
    """Noise-free readings of ``TRUE`` with a gain drift (a slow bump, about 4 % peak) about a sensor zero
    at ``pivot_fraction`` of the output's range; the zero (um) and the clean output."""
    clean = predict_run(TRUE, run_of(np.zeros(V.size)))
    pivot = float(clean.min() + pivot_fraction * np.ptp(clean))
    g = 0.04 * np.exp(-(((T - 0.6 * T[-1]) / (0.2 * T[-1])) ** 2))
    return clean + (clean - pivot) * g, pivot, clean


def test_a_gain_drift_pivots_about_the_sensor_zero_where_the_fit_finds_it():
    y, pivot, clean = _gain_about(1.0)
    assert np.allclose(y[np.abs(clean - pivot) < 1e-12], clean[np.abs(clean - pivot) < 1e-12])
    fit = fit_with_effects(GRID, [run_of(y)], "ls", [make_effect("gain_drift")])
    (gain,) = fit.model.effects
    span = float(np.ptp(clean))
    # the fit's pivots are fractions of its own output's range, so it lands within a grid step of the truth
    assert abs(gain.pivot_um - pivot) <= 0.15 * span
    plain = fit_with_effects(GRID, [run_of(y)], "ls", [])
    # a gain about the reading's zero (0 um, mid-loop here) cannot follow it: the pivot is what closes it
    assert abs(pivot) > 0.4 * span
    assert fit.rmse < 0.2 * plain.rmse
    assert gain.report()["pivot_um"] == gain.pivot_um
    # stored and read back, the zero stays; on another run the same sensor keeps it, its drift its own
    back = model_from_dict(model_to_dict(fit.model))
    assert back.effects[0].pivot_um == gain.pivot_um
    other = gain.for_another_run()
    assert not other.fitted and other.pivot_known and other.pivot_um == gain.pivot_um
    assert len(other.settings_grid()) < len(EFFECTS["gain_drift"]().settings_grid())


def test_a_gain_drift_stored_without_a_pivot_reads_as_about_the_reading_zero():
    params = _drift_params()
    old = EFFECTS["gain_drift"](params)  # as stored before the pivot was a setting
    assert old.pivot_um == 0.0
    u = np.linspace(1.0, 3.0, V.size)
    run = run_of(np.zeros(V.size))
    assert np.allclose(old.contribution(run, u), u * old.gain(run))
    moved = EFFECTS["gain_drift"]({**params, "pivot_um": 2.0})
    assert np.allclose(moved.contribution(run, u), (u - 2.0) * moved.gain(run))
    with pytest.raises(IdentifyError, match="pivot_um"):
        EFFECTS["gain_drift"]({**params, "pivot_um": float("nan")})


# ---------------------------------------------------------------- the command line
def _session(tmp_path, y, name="fit.h5", dwell=None):
    """A real session file of the design above with outputs ``y``: time stamps and dwells recorded."""
    from identify import Excitation
    from sessions import ExcitationRecord, SessionWriter

    path = tmp_path / name
    record = ExcitationRecord.from_excitation(Excitation("random", GRID, V))
    w = SessionWriter.create(path, record, fsync_interval_s=None)
    for k in range(V.size):
        d = float(DWELL[k] if dwell is None else dwell)
        w.append(float(T[k]), float(V[k]), float(y[k]), measured=True, settled=True, dwell_s=d)
    w.finish("complete", "test")
    return path


def test_rig_identify_with_stores_the_effects_and_predict_and_validate_use_them(tmp_path):
    truth, _, y = _truth("joule_power")
    path = _session(tmp_path, y)
    run = rig("identify", path, "--with", "joule_power", "--json", "--save", tmp_path / "m.json")
    assert run.code == 0, run.err
    out = run.json()
    assert out["name"] == "ls+joule_power"
    assert [e["name"] for e in out["effects"]] == ["joule_power"]
    assert out["effects"][0]["params"]["um_per_V2"] == pytest.approx(0.07, rel=1e-6)
    assert out["effects"][0]["params"]["um_per_V4"] == pytest.approx(-0.002, rel=1e-6)
    stored = read_session(path).models["ls+joule_power"]
    assert isinstance(stored, ModelRecord) and stored.model.effects[0].params == out["effects"][0]["params"]
    pred = rig("predict", tmp_path / "m.json", path, "--json")
    assert pred.code == 0, pred.err
    assert pred.json()["rmse_um"] < 1e-8
    val = rig("validate", path, "--model", "ls+joule_power", "--on", path, "--json")
    assert val.code == 0, val.err
    assert val.json()["effects"] == ["joule_power"] and val.json()["rmse"] < 1e-8


def test_a_fed_back_fit_says_how_the_model_predicts_its_run_on_its_own(tmp_path):
    from identify.fit import fit_run, simulated_rmse

    # noise-free data of a true mean field: fed back or not, the model reproduces its run
    truth, _, y = _truth("interaction")
    run = run_of(y)
    report = fit_run(GRID, run, "ls", [make_effect("interaction")])
    assert report.info["simulated_rmse"] == pytest.approx(simulated_rmse(report.model, run))
    assert report.info["simulated_rmse"] < 1e-6 * float(np.ptp(y))
    # without a loop there is nothing fed back, and nothing to say
    assert "simulated_rmse" not in fit_run(GRID, run, "ls", [make_effect("joule_power")]).info
    # a model whose mean field the data do not hold: the fit leans on the measured output, its own
    # prediction does not, and the command line says how far apart they are
    rng = np.random.default_rng(3)
    plain = predict_run(replace(TRUE, effects=()), run_of(np.zeros(V.size))) + 0.3 * np.sin(T / 900.0)
    path = _session(tmp_path, plain + 0.002 * rng.standard_normal(V.size))
    out = rig("identify", path, "--with", "interaction", "--json", "--no-store")
    assert out.code == 0, out.err
    js = out.json()
    fitted = fit_run(GRID, run_of(plain), "ls", [make_effect("interaction")])
    assert js["simulated_rmse_um"] > js["rmse_um"]  # the fit minimised the fed-back error, not this one
    assert fitted.info["simulated_rmse"] == pytest.approx(simulated_rmse(fitted.model, run_of(plain)))
    text = rig("identify", path, "--with", "interaction", "--no-store")
    assert text.code == 0 and "on its own" in text.out


def test_rig_identify_with_bad_effects_is_one_line_and_changes_nothing(tmp_path):
    truth, _, y = _truth("joule_power")
    path = _session(tmp_path, y)
    before = digest(path)
    assert_one_line_error(rig("identify", path, "--with", "creeep"), "unknown effect 'creeep'", "thermal_lag")
    assert_one_line_error(rig("identify", path, "--method", "cs", "--with", "creep"), "square", "ls or smooth_nn")
    # every dwell the same: a thermal lag's time constant cannot be told from its size
    same = _session(tmp_path, y, "same.h5", dwell=20.0)
    assert_one_line_error(rig("identify", same, "--with", "thermal_lag"), "thermal_lag cannot be identified",
                          "--dwells")
    assert digest(path) == before


def test_rig_report_draws_each_effect_over_the_run_beside_the_residual(tmp_path):
    from rig.plots.effects import effects_figure
    from rig.plots.style import DEFLECTION

    truth, _, y = _truth("first_point")
    path = _session(tmp_path, y)
    assert rig("identify", path, "--with", "first_point,joule_power", "--name", "fx").code == 0
    run = rig("report", path, "--model", "fx", "--out", tmp_path / "rep", "--json")
    assert run.code == 0, run.err
    assert str(tmp_path / "rep" / "effects.png") in run.json()["figures"]
    assert "![The model's effects over the run" in (tmp_path / "rep" / "report.md").read_text()
    # the figure itself: one panel per effect, then the residual, on one time axis
    parts = {"first_point": np.where(np.arange(V.size) % 7 == 0, 0.01, 0.0), "joule_power": 0.07 * V ** 2}
    fig = effects_figure(T, parts, np.arange(V.size), np.zeros(V.size), DEFLECTION)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["first_point (µm)", "joule_power (µm)", "residual (µm)"]
    np.testing.assert_allclose(fig.axes[1].lines[1].get_ydata(), parts["joule_power"])


def test_a_sensor_map_held_where_it_is_keeps_its_correction_in_the_linear_solve():
    """A step-halving re-solves the density with the sensor map held (no columns of its own): at the true map
    and density, that solve must give the true density back -- the map's correction is known, not refitted."""
    from identify.effects.joint import _Fitter

    truth, _, y = _truth("sensor_nonlinearity")
    sensor = truth.effects[0]
    fitter = _Fitter(GRID, (run_of(y),), "ls", None, [make_effect("sensor_nonlinearity")], True)
    at_truth = fitter.state(truth.without_effects(), (sensor,))
    model, _ = fitter.solve(at_truth.ctx, (sensor,), ({},), frozen=True)
    np.testing.assert_allclose(model.density, truth.density, atol=1e-7)
    assert model.mu0 == pytest.approx(truth.mu0, abs=1e-7) and model.c_d == pytest.approx(truth.c_d, abs=1e-7)


def test_a_first_point_offset_belongs_to_a_reading_not_to_a_point_applied_without_one():
    """A FORC returns towards saturation through points it does not read: a turn whose first point has no
    reading carries no first-point terms (nor does their persistence reach the readings after it), so a term
    the fit never saw is never extrapolated onto a held-out reading."""
    from identify.effects.first_point import indicators

    v = np.array([0.0, 1.0, 2.0, 3.0, 1.5, 0.5, 1.0, 2.0, 2.5, 2.8, 1.0, 0.2])
    y = np.arange(v.size, dtype=float)
    y[4] = np.nan                      # the first point after the reversal at 3 V is applied, not read
    run = run_of(y, v=v, dwell=np.full(v.size, 10.0), t=10.0 * np.arange(1, v.size + 1))
    terms = indicators(run, decay=0.6, cell=0.5)
    after = terms[:, 3:9]
    assert not np.any(after[4:6])      # no terms at the unread turn, nor persisting from it
    assert np.all(after[6] != 0)       # the turn at 0.5 V is read at 1.0 V: its first point carries them
    sat = 1.0 - np.exp(-1.0)  # a step of 0.5 V up, on a cell of 0.5 V: 1, d, s, d sat, |s|, sat
    np.testing.assert_allclose(after[6], [1.0, 1.0, 0.5, sat, 0.5, sat])
    np.testing.assert_allclose(after[7], 0.6 * after[6])


def test_the_first_rise_of_a_run_is_a_turn_with_its_own_offset():
    """Every run starts from the heater at 0 V, where the film cooled into saturation: the first set-point that
    rises from there is the first point after a turn, and carries the start offset (persisting like the others),
    not the size terms of a turn inside the run (its step is the whole jump from 0 V)."""
    from identify.effects.first_point import LABELS, indicators

    start = LABELS.index("start_offset_um")
    v = np.array([0.0, 0.0, 2.0, 3.0, 1.5, 2.5, 2.0, 1.0])
    run = run_of(np.arange(v.size, dtype=float), v=v, dwell=np.full(v.size, 10.0), t=10.0 * np.arange(1, v.size + 1))
    np.testing.assert_allclose(indicators(run, decay=0.0)[:, start], [0, 0, 1, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(indicators(run, decay=0.5)[:, start], [0, 0, 1, 0.5, 0.25, 0.125, 0.0625, 0])
    # the turns inside the run keep their own terms: at 1.5 V (after 3 V) and 2.0 V (after 2.5 V), none at 2 V
    assert not np.any(indicators(run, decay=0.0)[2, 3:9])
    # a run whose first move falls from its start turns nothing there (it continues the fall)
    down = run_of(np.arange(4, dtype=float), v=np.array([-1.0, -2.0, -1.0, -3.0]), dwell=np.full(4, 10.0),
                  t=10.0 * np.arange(1, 5))
    assert not np.any(indicators(down, decay=0.5)[:, start])


def _forc_like(reversals, step, name, seed):
    """First-order reversal curves on GRID: down from saturation through a calibration field (both applied, not
    read) to each reversal field,
    then read going up in (nearly) equal steps; noise of 1e-3 on a model without any first-point artefact."""
    rng = np.random.default_rng(seed)
    v = []
    for a in reversals:  # the fields as read: equal steps up to a jitter of 1e-4 V, as a magnet's are
        v += [4.0, 3.95, a] + list(np.arange(a + step, 4.0, step) + rng.normal(0.0, 1e-4))
    v = np.asarray(v)
    y = TRUE.predict(v) + rng.normal(0.0, 1e-3, v.size)
    y[(v == 4.0) | (v == 3.95)] = np.nan
    return Run(name, v, y, np.arange(1.0, v.size + 1), np.full(v.size, 1.0))


def test_first_point_terms_the_readings_cannot_tell_apart_are_not_fitted():
    """Every curve turns up by the same field step: the direction, step and saturating terms repeat the offset
    on the readings.  Fitted anyway they are an arbitrary cancellation that a curve read with another step
    turns into error; only the separable terms are fitted, so the held-out error stays at the noise."""
    fit = _forc_like(np.linspace(0.2, 3.6, 12), 0.25, "fit", 1)
    check = _forc_like(np.linspace(0.35, 3.5, 9), 0.4, "check", 2)
    joint = fit_with_effects(GRID, [fit], "ls", [make_effect("first_point")])
    coef = np.asarray(joint.model.effects[0].params["coefficients_um"])
    assert np.max(np.abs(coef)) < 0.05
    base = fit_with_effects(GRID, [fit], "ls", [])
    err = validate_run(joint.model, check).rmse
    assert err < 1.5 * validate_run(base.model, check).rmse


@pytest.mark.parametrize("form", ["shift", "gain"])
def test_ambient_drift_secants_are_one_replay_per_spline_to_the_bit(form):
    # the secants are replayed in one batch (Context.responses); each must be the one-spline-at-a-time
    # secant exactly, so a diagnosis or a discriminating design built on them does not change
    from identify.effects import Context
    from identify.effects.ambient_drift import SECANT, AmbientDrift, moved_input

    v = 1.0 + 0.75 * V
    run = run_of(np.zeros(v.size), v=v)
    ctx = Context.of_model(TRUE, [run])
    drift = AmbientDrift({**_drift_params(), "form": form})
    cols = drift.nuisance_columns(ctx, {"smoothing": 0.0})
    basis = splines_at(time_knots(run), T)
    step = SECANT * (GRID.step ** 2 if form == "shift" else GRID.step / (GRID.v_max - GRID.v_min))
    d = drift.drift(run)
    assert np.any(d)
    base = ctx.response(0, v)
    one_by_one = np.column_stack([(ctx.response(0, moved_input(v, d + step * basis[:, j], form)) - base) / step
                                  for j in range(basis.shape[1])])
    assert np.array_equal(cols.values[0], one_by_one)


def test_a_drift_spline_never_has_more_spans_than_a_quarter_of_the_points():
    n = 40
    days = run_of(np.zeros(n), v=np.linspace(0.5, 3.5, n), dwell=np.full(n, 86400.0), t=86400.0 * np.arange(1, n + 1))
    knots = time_knots(days, 200.0)
    assert np.unique(knots).size - 1 == n // 4  # spans, not 17,000 of 200 s
    assert splines_at(knots, days.t_s).shape == (n, n // 4 + 3)
    # a run dense in time keeps its spans about every knot_s
    dense = run_of(np.zeros(V.size))
    assert np.unique(time_knots(dense, 600.0)).size - 1 == int(np.ptp(T) // 600.0) + 1


@pytest.mark.parametrize("drive", ["power", "voltage"])
def test_a_small_lag_is_predicted_by_its_columns(drive):
    """The lag's columns at no lag are its derivative there: a lag just above the noise (a fraction of 0.003
    in one mode) changes the output by what they predict.  A secant to a twenty-times larger lag (the step
    used until 2026-11-29) crosses cells of the memory curve such a lag never reaches, and is off by more."""
    from identify.effects.joint import context_of
    from identify.effects.thermal_lag import TIME_CONSTANTS_S, lagged

    # from 0.5 V: a power-driven lag at 0 V (a beam still warm) grows as the square root of its fraction,
    # which no linearisation follows
    v = 0.5 + 0.875 * V
    run = run_of(TRUE.predict(v), v=v)
    lag = make_effect("thermal_lag")
    ctx = context_of(TRUE, [run], (lag,))
    cols = lag.columns(ctx, {"drive": drive}).values[0]
    fractions = np.zeros(len(TIME_CONSTANTS_S))
    fractions[7] = 0.003  # the mode at 62 s, beside dwells of 5-60 s
    x = lagged(run, np.asarray(TIME_CONSTANTS_S), fractions, drive=drive)
    exact = ctx.response(0, x, x) - ctx.response(0, run.inputs, run.inputs)
    error = np.linalg.norm(cols @ fractions - exact) / np.linalg.norm(exact)
    assert error < 0.03, error


def test_a_lag_mode_no_run_can_see_is_not_fitted():
    """A mode far faster than every dwell has settled at every reading: its column is zero, not a rounding
    error a fit could give any fraction to; a mode a fit has put at its whole fraction stays visible."""
    from identify.effects.joint import context_of
    from identify.effects.thermal_lag import TIME_CONSTANTS_S, ThermalLag

    v = 0.5 + 0.875 * V  # from 0.5 V (at 0 V a power-driven lag's input grows as the square root), dwells 5-60 s
    run = run_of(TRUE.predict(v), v=v)
    lag = make_effect("thermal_lag")
    cols = lag.columns(context_of(TRUE, [run], (lag,)), {"drive": "power"}).values[0]
    assert TIME_CONSTANTS_S[0] == 0.5 and not np.any(cols[:, 0])
    assert np.any(cols[:, 7])  # 62 s
    whole = np.zeros(len(TIME_CONSTANTS_S))
    whole[7] = 1.0
    fitted = ThermalLag({"drive": "power", "time_constants_s": list(TIME_CONSTANTS_S), "fractions": whole.tolist()})
    at = fitted.columns(context_of(replace(TRUE, effects=(fitted,)), [run], (fitted,)), {}).values[0]
    assert np.any(at[:, 7]) and not np.any(at[:, 0])
