"""MicroMag FORC files: both header styles, the reconstructed input history, times, drift, bad files."""

from __future__ import annotations

import numpy as np
import pytest

from identify import Grid, PreisachModel
from sessions import DataFileError, SampleFlag, read_session
from sessions.forc_import import import_forc
from sessions.forc_protocol import SweepSettings, protocol_history
from sessions.micromag import read_forc, read_micromag

from .forcfiles import Relays, forc_data, lines_0015, lines_0016, shared_forc, write_lines

#: Reversal fields of the test measurement (T), highest first, as a FORC script runs them.
REVERSALS = np.round(np.arange(0.02, -0.0801, -0.01), 9)


def trapezoid_tops(reversals, hb2=0.02, hc2=0.06):
    """Each curve's last field: the Hb <= Hb2 and Hc <= Hc2 bounds of a FORC script."""
    return np.minimum(2 * hb2 - reversals, reversals + 2 * hc2)


@pytest.fixture
def relays():
    return Relays.random(60, -0.09, 0.09, seed=3, bias=0.25, slope=2.0)


@pytest.fixture
def data(relays):
    return forc_data(relays, REVERSALS, 0.005, trapezoid_tops(REVERSALS), {"elapsed": 250.0})


def test_series_0016_file_is_read_as_written(tmp_path, data):
    path = write_lines(tmp_path / "a.forc", lines_0016(data))
    raw = path.read_bytes()
    assert b"\r\n" in raw and b"(Am\xb2)" in raw  # CRLF and a Latin-1 superscript two, as the instrument writes
    forc = read_forc(path)
    h = forc.header
    assert (h.style, h.series, h.field_unit, h.moment_unit) == ("0016", "0016.002", "T", "A m^2")
    assert h.number("h_sat", path) == 0.5 and h.number("h_cal", path) == 0.12
    assert h.number("pause_reversal", path) == 0.5 and h.number("n_forc", path) == len(REVERSALS)
    assert h.text("description") == "test sample" and h.text("sweep_mode") == "Continuous"
    lines = lines_0016(data)
    assert h.entry("h_sat").line == 1 + next(k for k, ln in enumerate(lines) if ln.startswith("HSat"))
    assert len(forc.curves) == len(forc.calibration) == len(REVERSALS)
    for seg, f, m in zip(forc.curves, data.fields, data.moments):
        np.testing.assert_array_equal(seg.field, f)
        np.testing.assert_array_equal(seg.moment, m)
    assert forc.curves[0].field.size == 1  # the top corner: a curve of its reversal point only
    np.testing.assert_array_equal([c.moment[0] for c in forc.calibration], data.cal_moment)


def test_series_0015_file_is_read_as_written(tmp_path, data):
    path = write_lines(tmp_path / "b.frc", lines_0015(data), newline="\n")
    forc = read_forc(path)
    h = forc.header
    assert (h.style, h.series, h.field_unit, h.moment_unit) == ("0015", "0015", "Oe", "emu")
    assert h.number("pause_reversal", path) == 0.5  # PauseNtl
    assert h.number("n_forc", path) == len(REVERSALS)  # NCrv
    assert h.number("n_data", path) == data.n_data  # NData
    assert h.text("measured_on") == "01/22/2015  17:35" and h.text("description") == "test sample"
    assert h.sections["INSTRUMENT"]["Units of measure"].text == "cgs"
    assert not forc.source.end_marker
    for seg, f, m in zip(forc.curves, data.fields, data.moments):
        np.testing.assert_array_equal(seg.field, f)
        np.testing.assert_array_equal(seg.moment, m)


def test_both_styles_give_the_same_session_but_for_the_units(tmp_path, data):
    a = tmp_path / "a.h5"
    b = tmp_path / "b.h5"
    import_forc(read_forc(write_lines(tmp_path / "a.forc", lines_0016(data))), a)
    import_forc(read_forc(write_lines(tmp_path / "b.frc", lines_0015(data))), b)
    sa, sb = read_session(a), read_session(b)
    for col in ("t_s", "input", "output", "raw", "measured", "flags"):
        np.testing.assert_array_equal(sa.samples[col], sb.samples[col])
    np.testing.assert_array_equal(sa.curves, sb.curves)
    assert (sa.quantities.input_unit, sa.quantities.output_unit) == ("T", "A m^2")
    assert (sb.quantities.input_unit, sb.quantities.output_unit) == ("Oe", "emu")
    assert sa.excitation.extra["header_style"] == "0016" and sb.excitation.extra["header_style"] == "0015"


def test_the_imported_history_puts_every_point_in_its_memory_state(tmp_path, relays, data):
    """Stepping relays through the whole imported history gives the closed-form FORC output at
    every measured point, and a grid Preisach model predicts the long history exactly as it
    predicts each curve's protocol run on its own."""
    out = tmp_path / "s.h5"
    import_forc(read_forc(write_lines(tmp_path / "a.forc", lines_0016(data))), out)
    s = read_session(out)
    rows = s.measured_rows
    np.testing.assert_array_equal(s.outputs[rows], np.concatenate(data.moments))  # as written
    # 1. a simulation that never saw the protocol: relays stepped through the imported inputs
    np.testing.assert_allclose(relays.simulate(s.inputs)[rows], s.outputs[rows], rtol=0, atol=1e-12)
    # 2. a grid model: the long history against each curve run alone from saturation
    grid = Grid(12, -0.08, 0.1)
    model = PreisachModel(grid, np.random.default_rng(5).uniform(0, 1, grid.n_cells), mu0=0.1, c_d=0.3)
    long = model.predict(s.inputs)
    for k, (f, cal) in enumerate(zip(data.fields, data.cal_field)):
        alone = model.predict(np.concatenate([[0.5, cal], f]))[2:]
        np.testing.assert_allclose(long[s.curves == k], alone, rtol=0, atol=1e-12)
    # the layout: HSat, HCal, then the curve, flagged
    first = np.flatnonzero(s.curves == 3)[0]
    assert s.inputs[first - 2] == 0.5 and s.inputs[first - 1] == data.cal_field[3]
    assert s.samples["flags"][first - 2] & SampleFlag.SATURATION and s.samples["flags"][first] & SampleFlag.REVERSAL
    assert s.samples["flags"][first - 1] & SampleFlag.CALIBRATION and not s.measured[first - 1]
    assert s.calibration.row[3] == first - 1 and s.calibration.curve[3] == 3
    assert np.all(s.curves[~s.measured] == -1) and np.all(s.curves[s.measured] >= 0)


def test_times_follow_the_sweep_settings_and_the_elapsed_time(tmp_path, relays):
    reversals = np.array([0.0, -0.01])
    data = forc_data(relays, reversals, 0.005, 0.01, {"slew": 0.5, "elapsed": None})
    forc = read_forc(write_lines(tmp_path / "t.forc", lines_0016(data)))
    s = SweepSettings.from_header(forc.header, forc.path)
    t = protocol_history(forc, s).t_s
    cal = data.cal_field[0]  # 0.1199
    # from 0 T up to HSat at 0.5 T/s: 1 s; pause 2 s; down to HCal; pause 1 s; half the 0.1 s average
    hand = [1.0, 3.0 + (0.5 - cal) / 0.5 + 1.0 + 0.05]
    end = hand[-1] + 0.05
    hand.append(end + cal / 0.5 + 0.5 + 0.05)  # reversal at 0 T: pause 0.5 s
    hand += [hand[-1] + 0.05 + 0.01 + 0.05, hand[-1] + 2 * (0.05 + 0.01 + 0.05)]  # 5 mT steps: 0.01 s each
    np.testing.assert_allclose(t[:5], hand, rtol=0, atol=1e-12)
    # with the header's elapsed time, the surplus is spread over the measured points
    nominal = protocol_history(forc, s).timing["nominal_s"]
    s2 = SweepSettings(**{**s.to_dict(), "elapsed_s": nominal + 10 * 0.25})
    h2 = protocol_history(forc, s2)
    assert h2.timing["overhead_per_point_s"] == pytest.approx(0.25)  # 2 calibration + 3 + 5 curve points
    np.testing.assert_allclose(np.diff(h2.t_s)[2:4] - np.diff(t)[2:4], [0.25, 0.25])


def test_drift_correction_from_the_calibration_points(tmp_path, relays):
    """A sensitivity drifting linearly in time until the last calibration point is undone exactly
    (up to its mean): the correction is linear between calibration points, constant after the last."""
    plain = forc_data(relays, REVERSALS, 0.005, trapezoid_tops(REVERSALS))
    forc = read_forc(write_lines(tmp_path / "p.forc", lines_0016(plain)))
    h = protocol_history(forc, SweepSettings.from_header(forc.header, forc.path))  # times need no moments
    last = h.t_s[h.calibration_rows[-1]]
    gain = 1 + 0.002 * np.minimum(h.t_s, last) / last
    drifted = forc_data(relays, REVERSALS, 0.005, trapezoid_tops(REVERSALS))
    drifted.cal_moment = list(np.array(plain.cal_moment) * gain[h.calibration_rows])
    drifted.moments = [m * gain[h.curve == k] for k, m in enumerate(plain.moments)]
    path = write_lines(tmp_path / "d.forc", lines_0016(drifted))
    out = tmp_path / "d.h5"
    import_forc(read_forc(path), out, drift="scale")
    s = read_session(out)
    rows = s.measured_rows
    assert s.drift_correction["mode"] == "scale" and "drift-corrected (scale)" in s.events[-2].message
    reference = s.drift_correction["reference"]
    assert reference == pytest.approx(np.mean(s.calibration.output))
    written = np.concatenate(drifted.moments)
    np.testing.assert_allclose(s.samples["raw"][rows], written, rtol=1e-6)  # the moments as recorded
    np.testing.assert_allclose(s.outputs[rows], np.concatenate(plain.moments) * reference / plain.cal_moment[0],
                               rtol=1e-6)
    # off by default: the outputs are the moments as recorded
    import_forc(read_forc(path), tmp_path / "n.h5")
    n = read_session(tmp_path / "n.h5")
    assert n.drift_correction is None
    np.testing.assert_allclose(n.outputs[rows], written, rtol=1e-6)


# ------------------------------------------------------------------ bad files
def edited(lines, k, new):
    lines = list(lines)
    if new is None:
        del lines[k]
    else:
        lines[k] = new
    return lines


def first_data_line(lines):
    return next(k for k, ln in enumerate(lines) if ln[:1] in "+-" and "," in ln)


@pytest.mark.parametrize("edit, fragments", [
    (lambda ls: ls[: first_data_line(ls) + 40], ["truncated", "announces", "ends at line"]),
    (lambda ls: edited(ls, first_data_line(ls) + 7, "+12.00000E-03,+1.2E"), ["line {n}", "two numbers"]),
    (lambda ls: edited(ls, first_data_line(ls) + 7, "+12.00000E-03"), ["line {n}", "field,moment"]),
    (lambda ls: edited(ls, first_data_line(ls) + 1, "+119.9000E-03,+1.000000E+00"),
     ["line {p}", "one-point calibration", "lines {p}-"]),
    (lambda ls: edited(ls, first_data_line(ls) + 9, "-90.00000E-03,+1.000000E+00"), ["line {n}", "field falls"]),
    (lambda ls: [ln for ln in ls if not ln.startswith("HSat")], ["HSat", "missing"]),
    (lambda ls: edited(ls, 0, "Lake Shore data file"), ["line 1", "not a MicroMag"]),
    (lambda ls: edited(ls, 1, "Direct moment vs. field; Hysteresis loop"), ["line 2", "not first-order"]),
    (lambda ls: [f"{'SlewRate':<32}fast" if ln.startswith("SlewRate") else ln for ln in ls],
     ["line {n}", "SlewRate", "not a number"]),
])
def test_malformed_series_0016_files_name_the_line(tmp_path, data, edit, fragments):
    good = lines_0016(data)
    bad = edit(good)
    changed = next((k for k, (a, b) in enumerate(zip(good, bad)) if a != b), len(bad))
    path = write_lines(tmp_path / "bad.forc", bad)
    with pytest.raises(DataFileError) as err:
        forc = read_forc(path)
        SweepSettings.from_header(forc.header, path)
    message = str(err.value)
    assert message.startswith(str(path))
    for f in fragments:
        assert f.format(n=changed + 1, p=changed).lower() in message.lower(), message


def test_malformed_series_0015_files(tmp_path, data):
    good = lines_0015(data)
    path = write_lines(tmp_path / "u.frc", [ln.replace("cgs", "mks") for ln in good])
    with pytest.raises(DataFileError, match="line 6: units of measure 'mks' are not understood"):
        read_micromag(path)
    k = next(k for k, ln in enumerate(good) if ln.startswith("Hc2"))
    path = write_lines(tmp_path / "v.frc", edited(good, k, "Hc2 is eighty"))
    with pytest.raises(DataFileError, match=f"line {k + 1}: expected 'Key = value'"):
        read_micromag(path)
    path = write_lines(tmp_path / "w.frc", good[:-30])  # NData says more
    with pytest.raises(DataFileError, match="truncated: the header .* announces"):
        read_forc(path)


# ------------------------------------------------------------------ the shared measurement
def test_the_shared_measurement(tmp_path):
    """MD00-2361.forc (Series 0016): 297 curves after 297 calibration points; curve 0 is its reversal
    point alone, curves 1..228 end at the Hb bound (2k + 1 points), the rest span 458 points."""
    forc = read_forc(shared_forc())
    lengths = np.array([len(c) for c in forc.curves])
    assert (len(forc.calibration), len(forc.curves), forc.n_points) == (297, 297, 83585)
    np.testing.assert_array_equal(lengths[:229], 2 * np.arange(229) + 1)
    assert np.all(lengths[229:] == 458)
    assert (forc.header.field_unit, forc.header.moment_unit) == ("T", "A m^2")
    out = tmp_path / "md.h5"
    history = import_forc(forc, out)
    assert history.timing["overhead_per_point_s"] == pytest.approx(0.0238, abs=5e-4)
    s = read_session(out)
    assert s.n_samples == 83585 + 2 * 297 and s.measured.sum() == 83585
    assert s.t_s[-1] < 19991.81 and np.all(np.diff(s.t_s) > 0)


@pytest.mark.parametrize("style", ["0016", "0015"])
def test_a_bad_file_over_an_existing_session_exits_2_and_touches_nothing(tmp_path, data, style):
    from .cli import assert_one_line_error, rig_here

    lines = (lines_0016 if style == "0016" else lines_0015)(data)
    good = write_lines(tmp_path / "good.forc", lines)
    out = tmp_path / "s.h5"
    assert rig_here("import", "--format", "micromag", good, "--out", out).code == 0
    session_before = out.read_bytes()
    cut = first_data_line(lines) + 25
    bad = write_lines(tmp_path / "bad.forc", lines[:cut] + ["+12.00000E-03,+1.2E"] + lines[cut + 1:])
    file_before = bad.read_bytes()
    run = rig_here("import", "--format", "micromag", bad, "--out", out, "--force")
    assert_one_line_error(run, f"line {cut + 1}")
    assert out.read_bytes() == session_before and bad.read_bytes() == file_before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.forc", "good.forc", "s.h5"]
