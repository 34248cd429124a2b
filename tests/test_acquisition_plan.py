"""Planning an acquisition: reversal points, the compressive plan, dwell policies and settle conditions."""

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.clock import RealClock, VirtualClock
from drivers.protocols import Calibration, Reading, VoltageWindow
from identify import Grid, IdentifyError, MemoryCurve, damped_oscillation
from identify.acquisition_plan import compressive_plan, reversal_points
from rig.acquisition import (
    AcquisitionError,
    AcquisitionPlan,
    DwellSettings,
    FixedDwell,
    RateBelow,
    SettleDwell,
    Transit,
    make_record,
    sequence_dwells,
    sequence_record,
    time_budget,
)
from sessions import DataFileError, SampleFlag


# ---------------------------------------------------------------- reversal points
@pytest.mark.parametrize("inputs, expected", [
    ([1, 2, 3], [2]),                # a rise from saturation: only the top turns (back to 0 V after)
    ([3, 2, 1], [0]),                # falls after the first point, and keeps falling to 0 V
    ([1, 3, 3, 2], [2]),             # a plateau turns at its last point
    ([1, 1, 1], [2]),
    ([2, 1, 0, 1, 1.5], [0, 2, 4]),  # damped oscillation L = 2 on [0, 2] with the thermal point
    ([0, 5, 1, 4, 2, 3], [1, 2, 3, 4, 5]),
    ([4], [0]),
])
def test_reversal_points_by_hand(inputs, expected):
    assert np.flatnonzero(reversal_points(np.array(inputs, float))).tolist() == expected


def test_damped_oscillation_reverses_once_per_sweep():
    for levels in (1, 2, 5, 30):
        v = damped_oscillation(Grid(levels, 0.0, 6.0), thermal_term=True)
        rev = reversal_points(v)
        # the first point, the ends of the first L - 1 sweeps, the end of the last sweep when it
        # falls (the input turns up to the thermal point), and the thermal point
        last_sweep_falls = levels == 1 or v[-2] < v[-3]
        assert rev.sum() == 1 + (levels - 1) + last_sweep_falls + 1
        assert rev[0] and rev[-1] and rev[-2] == last_sweep_falls


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 12), min_size=1, max_size=40))
def test_memory_at_every_point_depends_only_on_the_reversals_before_it(xs):
    """Why compressive acquisition may pass through non-reversal points without settling: the memory
    curve after any prefix equals that after the prefix's reversal points and its last point."""
    x = np.array(xs, float) / 2  # coordinates on a 6-level grid, with plateaus and on-wall values
    rev = reversal_points(x)
    full, short = MemoryCurve(6), MemoryCurve(6)
    for k in range(x.size):
        full.apply(x[k])
        probe = short.copy()
        probe.apply(x[k])
        assert probe == full, k
        if rev[k]:
            short.apply(x[k])


def test_reversals_refuse_non_finite_inputs():
    with pytest.raises(IdentifyError, match="finite"):
        reversal_points(np.array([1.0, np.nan]))


# ---------------------------------------------------------------- compressive plan
def test_compressive_plan_measures_m_points_with_every_reversal():
    v = damped_oscillation(Grid(30, 0.0, 6.0), thermal_term=True)
    rev = reversal_points(v)
    plan = compressive_plan(v.size, 100, 5, rev)
    assert plan.sum() == 100 and np.all(plan[rev])
    assert np.array_equal(plan, compressive_plan(v.size, 100, 5, rev))  # seeded
    assert not np.array_equal(plan, compressive_plan(v.size, 100, 6, rev))
    assert compressive_plan(v.size, None, 0, rev).all()
    assert compressive_plan(v.size, int(rev.sum()), 0, rev).tolist() == rev.tolist()


@pytest.mark.parametrize("m, match", [(30, "fewer than the 31 reversal points"), (0, "between 1 and N=467"),
                                      (468, "between 1 and N=467")])
def test_compressive_plan_refuses_impossible_m(m, match):
    v = damped_oscillation(Grid(30, 0.0, 6.0), thermal_term=True)
    with pytest.raises(IdentifyError, match=match):
        compressive_plan(v.size, m, 0, reversal_points(v))


def test_record_and_plan_of_a_compressive_damped_run():
    window = VoltageWindow(0.0, 6.0)
    settings_ = DwellSettings(FixedDwell(20.0), Transit(0.5), readings=3)
    rec = make_record(sequence_record("damped", window, levels=4), settings_, measure=8, seed=2)
    assert rec.kind == "damped" and rec.levels == 4 and rec.thermal_term and rec.n_points == 12
    assert rec.dwell == {"policy": "fixed", "seconds": 20.0, "transit_s": 0.5, "readings": 3}
    assert rec.extra == {"n_reversals": 5, "n_measured": 8, "measure": 8, "measure_seed": 2}
    plan = AcquisitionPlan.from_record(rec)
    assert plan.measure.sum() == 8 and np.all(plan.measure[plan.reversals])
    assert np.array_equal(plan.settle, plan.measure)  # reversals are measured, so they settle
    assert plan.flags[-1] == SampleFlag.REVERSAL | SampleFlag.THERMAL_POINT
    assert np.array_equal(plan.flags[:-1] == SampleFlag.REVERSAL, plan.reversals[:-1])
    with pytest.raises(AcquisitionError, match=r"point 0 of the plan \(6 V\) is outside .* \[0, 5\] V"):
        plan.check_window(VoltageWindow(0.0, 5.0))


def test_sequence_from_a_csv_file(tmp_path):
    window = VoltageWindow(0.0, 6.0)
    f = tmp_path / "sp.csv"
    f.write_text("note,v_V\na,1.5\nb,4\n\nc,2.25\n")
    rec = sequence_record(str(f), window)
    assert rec.kind == "file" and rec.levels is None and rec.inputs.tolist() == [1.5, 4.0, 2.25]
    assert rec.extra["source"] == "sp.csv" and len(rec.extra["source_sha256"]) == 64
    # the damped oscillation of the given grid is recognised, as rig import does
    f.write_text("v_V\n" + "\n".join(repr(float(x)) for x in damped_oscillation(Grid(3, 0.0, 6.0), True)) + "\n")
    rec = sequence_record(str(f), window, levels=3)
    assert (rec.kind, rec.levels, rec.v_min, rec.v_max, rec.thermal_term) == ("damped", 3, 0.0, 6.0, True)


@pytest.mark.parametrize("text, match", [
    ("", "empty file"),
    ("t_s,volts\n0,1\n", "no v_V column"),
    ("v_V\n1\nabc\n", "line 3: v_V value 'abc' is not a number"),
    ("v_V\ninf\n", "line 2: v_V value 'inf' is not finite"),
    ("a,v_V\n1\n", "line 2: expected 2 values, got 1"),
    ("v_V\n", "no set-points"),
])
def test_bad_setpoint_files_are_named(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(DataFileError, match=match):
        sequence_record(str(f), VoltageWindow(0.0, 6.0))


def test_sequence_name_typos_and_misplaced_options():
    with pytest.raises(DataFileError, match="expected damped, random, check, damped\\+check or a CSV file"):
        sequence_record("dampd", VoltageWindow(0.0, 6.0))
    with pytest.raises(DataFileError, match="--points"):
        sequence_record("damped", VoltageWindow(0.0, 6.0), points=10)


def test_damped_plus_check_is_the_damped_oscillation_then_a_check_design_with_its_dwells():
    window = VoltageWindow(0.0, 6.0)
    record = sequence_record("damped+check", window, points=40, seed=3)
    damped = sequence_record("damped", window)
    n = damped.n_points
    np.testing.assert_array_equal(record.inputs[:n], damped.inputs)
    assert record.n_points == n + 40 and record.extra["damped_points"] == n
    dwell = sequence_dwells("damped+check", window, points=40, seed=3, dwell=20.0)
    assert dwell.shape == (n + 40,) and np.all(dwell[:n] == 20.0)
    assert set(dwell[n:]) <= set(record.extra["dwell_choices_s"]) and len(set(dwell[n:])) > 1
    # --dwells: each point of the damped part draws one of the choices (seeded), all of them used
    varied = sequence_dwells("damped", window, seed=1, choices=(8.0, 60.0))
    again = sequence_dwells("damped", window, seed=1, choices=(8.0, 60.0))
    assert varied.shape == (n,) and set(varied) == {8.0, 60.0}
    np.testing.assert_array_equal(varied, again)
    with pytest.raises(DataFileError, match="their own"):
        sequence_dwells("check", window, choices=(8.0,))


# ---------------------------------------------------------------- dwell policies
class RelaxingBeam:
    """A sensor whose deflection relaxes as ``A exp(-t / tau)`` on a virtual clock (um, s): the rate of change is known."""

    def __init__(self, clock, amplitude_um=10.0, tau_s=1.0):
        self.clock, self.a, self.tau = clock, amplitude_um, tau_s
        self.calibration = Calibration(1.0)
        self.reads = 0

    def deflection(self, t):
        return self.a * math.exp(-t / self.tau)

    def read(self):
        self.reads += 1
        d = self.deflection(self.clock.now())
        return Reading(d, d, self.calibration)


def never():
    return False


def test_rate_below_needs_consecutive_quiet_polls():
    c = RateBelow(1.0, polls=2)
    for t, d in [(0, 0.0), (1, 5.0), (2, 5.5), (3, 9.0), (4, 9.2)]:
        c.observe(t, d)
    assert not c.met and c.rate == pytest.approx(0.2)  # 0.5 quiet, then 3.5 broke the run, then 0.2
    c.observe(5, 9.3)
    assert c.met
    c.reset()
    assert not c.met and math.isnan(c.rate)
    with pytest.raises(AcquisitionError):
        RateBelow(0.0)


def test_settle_dwell_ends_when_the_rate_is_below_the_threshold():
    clock = VirtualClock()
    beam = RelaxingBeam(clock, 10.0, 1.0)
    out = SettleDwell(RateBelow(0.05, polls=2), max_s=60, poll_s=0.5, readings=2).wait(clock, beam, never)
    assert out.settled and not out.timed_out
    # the finite-difference rate over the last two polls is below 0.05 um/s, and was not one poll earlier
    t = out.waited_s
    rate = [(beam.deflection(a) - beam.deflection(a + 0.5)) / 0.5 for a in (t - 1.5, t - 1.0, t - 0.5)]
    assert rate[0] >= 0.05 > rate[1] and rate[2] < 0.05
    assert beam.reads == 2 * (round(t / 0.5) + 1)


def test_settle_dwell_times_out_and_fixed_dwell_waits_exactly():
    clock = VirtualClock()
    out = SettleDwell(RateBelow(0.05), max_s=2.0, poll_s=0.5).wait(clock, RelaxingBeam(clock), never)
    assert (out.waited_s, out.settled, out.timed_out) == (2.0, False, True)
    out = FixedDwell(7.3).wait(clock, RelaxingBeam(clock), never)
    assert (out.waited_s, out.settled) == (pytest.approx(7.3), True) and clock.now() == pytest.approx(9.3)
    out = Transit(0.0).wait(clock, RelaxingBeam(clock), never)
    assert (out.waited_s, out.settled) == (0.0, False)


def test_a_pause_request_stops_a_real_time_dwell_within_a_slice():
    clock = RealClock()
    t_stop = time.monotonic() + 0.3
    out = FixedDwell(60.0).wait(clock, RelaxingBeam(clock), lambda: time.monotonic() >= t_stop)
    assert out is None and t_stop <= time.monotonic() <= t_stop + 0.25 + 0.5  # a slice, and a busy machine


class CountingClock(VirtualClock):
    def __init__(self):
        super().__init__()
        self.sleeps = 0

    def sleep(self, seconds):
        self.sleeps += 1
        super().sleep(seconds)


def test_a_virtual_clock_dwell_is_not_cut_into_slices():
    clock = CountingClock()
    out = FixedDwell(3600.0).wait(clock, RelaxingBeam(clock), never)
    assert out.waited_s == 3600.0 and clock.sleeps == 2  # one slice shows the clock is not real time


def test_dwell_settings_round_trip_through_their_description():
    for s in (DwellSettings(FixedDwell(12.5), Transit(0.25), 3),
              DwellSettings(SettleDwell(RateBelow(0.02, 3), 30.0, 0.2, 5), Transit(0.0), 5)):
        back = DwellSettings.from_description(s.describe())
        assert back.describe() == s.describe()
    with pytest.raises(AcquisitionError, match="not written by 'rig acquire'"):
        DwellSettings.from_description({"policy": "unknown"})
    with pytest.raises(AcquisitionError, match="malformed"):
        DwellSettings.from_description({"policy": "fixed"})
    with pytest.raises(AcquisitionError, match="readings"):
        DwellSettings(FixedDwell(1.0), readings=0)
    with pytest.raises(AcquisitionError, match="dwell"):
        FixedDwell(-1.0)


def test_time_budget_by_hand():
    # points take 10, 1, 10, 1, 10 s; the 1 s ones were not measured; point 4 is a reversal
    t = np.cumsum([10.0, 1.0, 10.0, 1.0, 10.0])
    measured = np.array([True, False, True, False, True])
    rev = np.array([False, False, False, False, True])
    rig_time, full = time_budget(t, measured, rev)
    assert rig_time == 32.0 and full == 50.0
    assert time_budget(t, np.ones(5, bool), rev) == (32.0, 32.0)
    assert time_budget(np.zeros(0), np.zeros(0, bool), np.zeros(0, bool)) == (0.0, 0.0)
