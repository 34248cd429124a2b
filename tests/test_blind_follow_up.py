"""The follow-up table of the blind benchmark (``benchmarks.blind.follow_up.table``), by hand."""

from __future__ import annotations

from benchmarks.blind.follow_up import before_of, table


def _row(seed, label, kind, outcome):
    return {"seed": seed, "label": label, "kind": kind, "outcome": outcome}


def test_a_case_re_simulated_with_other_readings_is_compared_with_those_readings_own_verdict():
    rows = [_row(1, "creep", "library", "wrong"), _row(2, "creep", "library", "open"),
            _row(3, "creep", "library", "right"), _row(1, "backlash", "outside", "right")]
    plan = {"plan": "p.csv", "predicted_separation": {"plan": 10.0, "check": 4.0}, "rig_time_s": 3600.0}
    followed = [
        # the same readings: the benchmark's verdict is the before
        {"seed": 1, "label": "creep", "after": "right", "discriminate": plan, "achieved_separation": {"a|b": -6.0}},
        # other readings of the first two runs: their own verdict (already right) is the before
        {"seed": 2, "label": "creep", "after": "right", "discriminate": plan, "before_same_readings": "right",
         "achieved_separation": {"a|b": 8.0, "a|c": 12.0}},
        {"seed": 1, "label": "backlash", "after": "wrong", "discriminate": {"plan": None}},
    ]
    assert before_of(rows[1], followed[1]) == "right" and before_of(rows[0], followed[0]) == "wrong"
    t = table(followed, rows)
    lib = t["library"]
    assert (lib["cases"], lib["right_before"], lib["right_after"]) == (3, 2, 3)
    assert (lib["wrong_before"], lib["wrong_after"], lib["new_realisations"]) == (1, 0, 1)
    assert lib["plans"] == 2 and lib["rig_time_s"] == 7200.0
    assert lib["achieved"] == 7.0  # the median over plans of each plan's least |separation|: 6 and 8
    out = t["outside"]
    assert (out["right_before"], out["right_after"], out["wrong_after"], out["plans"]) == (1, 0, 1, 0)
