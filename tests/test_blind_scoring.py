"""The blind benchmark's scoring: four columns from a verdict, and which names an outside case is tested against."""

from __future__ import annotations

from benchmarks.blind.scoring import classify, named_outside


def test_an_outside_mechanism_given_a_library_name_is_wrong_and_is_tested_against_that_name():
    named = {"status": "explained", "effects": ["sensor_nonlinearity"]}
    assert classify("outside", ["phase_reflectance"], named) == "wrong"
    assert named_outside("outside", named) == ["sensor_nonlinearity"]
    two = {"status": "explained", "effects": ["gain_drift", "ambient_drift"]}
    assert named_outside("outside", two) == ["gain_drift", "ambient_drift"]


def test_an_outside_mechanism_left_open_or_a_library_case_asks_for_no_named_oracle():
    for status in ("unexplained", "ambiguous", "cannot_tell"):
        verdict = {"status": status, "effects": [], "rivals": ["creep", "baseline_drift"]}
        assert classify("outside", ["accommodation"], verdict) == "right"
        assert named_outside("outside", verdict) == []
    assert named_outside("library", {"status": "explained", "effects": ["creep"]}) == []


def test_a_special_case_named_for_its_generalisation_is_right():
    # joule_power is declared a special case of reversible: naming it for a reversible device is right
    assert classify("library", ["reversible"], {"status": "explained", "effects": ["joule_power"]}) == "right"
    assert classify("library", ["reversible"], {"status": "explained", "effects": ["creep"]}) == "wrong"
