"""A session drift's twin on the clock of use: the clocks by hand, the verdict's rule, and the whole diagnosis."""

from __future__ import annotations

import numpy as np
import pytest

from identify import Grid
from identify.diagnosis import diagnose
from identify.diagnosis.use_clock import CLOCKS, stretched, twin_name, use_increments
from identify.diagnosis.verdict import Z_USE, Evidence

from .test_diagnosis import SIGMA, synthetic


def test_use_increments_by_hand():
    phase = np.array([0.0, 1.0, 3.0, 2.0, 2.0])
    assert use_increments(phase).tolist() == [0.0, 1.0, 2.0, 1.0, 0.0]
    with pytest.raises(ValueError, match="unknown clock"):
        use_increments(phase, "hours")
    assert CLOCKS == ("cycles",)


def test_use_is_stretched_onto_the_runs_time_span():
    t = np.array([0.0, 10.0, 20.0, 30.0])
    # used 0, 1, 1, 2 of 2: the clock stands still through the third point
    assert stretched(t, np.array([0.0, 1.0, 0.0, 1.0])).tolist() == [0.0, 15.0, 15.0, 30.0]
    assert stretched(t + 100.0, np.array([5.0, 1.0, 0.0, 1.0])).tolist() == [100.0, 115.0, 115.0, 130.0]
    # a run with no use at all keeps its time stamps
    assert stretched(t, np.zeros(4)).tolist() == t.tolist()


def _evidence(after_drift: np.ndarray, after_twin: np.ndarray, reference: np.ndarray, blocks: np.ndarray) -> Evidence:
    m = reference.size
    boot = np.tile([np.mean(reference**2), np.mean(after_drift**2)], (50, 1))
    return Evidence(("gain_drift",), reference, after_drift[None, :], np.full(m, SIGMA), 0.05, boot, False,
                    blocks=blocks, twins=("gain_drift",), twin_clocks=("cycles",), twins_after=after_twin[None, :])


def test_the_twins_advantage_is_judged_by_a_jackknife_over_held_out_blocks_by_hand():
    # squared residuals: the drift's exceed the twin's by 1, 1 | 2, 2 | 3, 3 in three blocks: mean 2; the
    # means without each block 2.5, 2, 1.5; se = sqrt(2/3 * 0.5) = 1/sqrt(3); z = 2 sqrt(3)
    d = np.array([1.0, 1.0, 2.0, 2.0, 3.0, 3.0])
    ev = _evidence(np.sqrt(d), np.zeros(6), np.full(6, 3.0), np.array([0, 0, 1, 1, 2, 2]))
    assert ev.use_z("gain_drift") == pytest.approx(2 * np.sqrt(3))
    assert ev.use_z("baseline_drift") is None  # no twin
    assert _evidence(np.sqrt(d), np.zeros(6), np.full(6, 3.0), np.array([0, 0, 0, 1, 1, 1])).use_z("gain_drift") is None


def test_a_drift_whose_twin_on_the_clock_of_use_is_clearly_better_is_not_named():
    rng = np.random.default_rng(7)
    m = 300
    blocks = np.repeat(np.arange(10), 30)
    noise = SIGMA * rng.normal(size=m)
    effect = 5 * SIGMA * np.sin(np.arange(m) / 9.0)
    ev = _evidence(noise + 0.3 * effect, noise, noise + effect, blocks)  # the drift closes most, the twin all
    assert ev.use_z("gain_drift") > Z_USE
    assert ev._decide().status == "explained" and ev._decide().effect == "gain_drift"
    v = ev.decide()
    assert v.status == "unexplained" and v.effect is None and v.contenders == ("gain_drift",)
    assert "cycles" in v.reason and "no library effect" in v.reason
    # the twin no better than the drift: the drift is named
    ev = _evidence(noise + 0.01 * effect, noise + 0.3 * effect, noise + effect, blocks)
    assert ev.use_z("gain_drift") < 0 and ev.decide().effect == "gain_drift"
    # a sub-library leaves the rule as it is
    assert ev.decide(exclude=("gain_drift",)).status == "unexplained"


GRID = Grid(12, 0.0, 6.0)


def test_an_offset_that_follows_the_films_switching_is_not_called_a_drift_of_the_clock():
    from drivers.sim import SimParams, SimVO2

    truth = SimVO2(SimParams(levels=GRID.levels)).true_model()

    def wear(v, t):  # the zero moves with each switch of the film, and stands still through a hold
        phase = truth.predict(v) - truth.mu0 - truth.c_d * v
        used = np.cumsum(np.abs(np.diff(phase, prepend=phase[0])))
        return 0.08 * used / used[-1]

    fit, check = synthetic(GRID, wear)
    d = diagnose([fit], [check], GRID, )
    assert d.verdict.status == "unexplained" and "cycles" in d.verdict.reason
    assert d.verdict.contenders[0] in ("baseline_drift", "gain_drift", "ambient_drift")
    assert d.evidence.use_z(d.verdict.contenders[0]) >= Z_USE
    # the JSON's use_clock: every session drift assessed, on the film's switching, with its z
    from rig.diagnosis.report import use_clock

    listed = {e["effect"]: e for e in use_clock(d)}
    assert set(listed) == {"baseline_drift", "ambient_drift", "gain_drift"}
    assert {e["clock"] for e in listed.values()} == {"cycles"}
    assert listed[d.verdict.contenders[0]]["z"] == pytest.approx(d.evidence.use_z(d.verdict.contenders[0]))
    assert twin_name("baseline_drift") == "baseline_drift@use"
