"""A file is judged by its content, and the message says what it is (issue 17, finding 5).

A damaged or random-bytes ``.h5`` used to be reported as "not a text (UTF-8)
CSV file" by identify, report, validate and predict, and ``rig predict`` took
CSV traces only.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from identify import Excitation, Grid
from identify.model_json import model_from_dict
from sessions.formats import HDF5_SIGNATURE, FileKind, detect

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model, write_csv
from .sessionkit import write_run


@pytest.fixture
def run(tmp_path):
    """A finished session of a compressive plan (every third point applied but not measured) with a model."""
    truth = known_model(6, v_min=0.0, v_max=3.0)
    exc = Excitation.random(truth.grid, 60, seed=2)
    measure = np.arange(60) % 3 != 1
    path, outputs = write_run(tmp_path / "run.h5", truth, exc, measure=measure)
    ident = rig_here("identify", path, "--levels", 6, "--name", "m", "--no-thermal-term", "--save",
                     tmp_path / "model.json")
    assert ident.code == 0, ident.err
    return truth, exc.inputs, outputs, path, tmp_path / "model.json"


def random_bytes(path, n=4096, seed=0):
    path.write_bytes(np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes())
    return path


def signature_lost(source, path):
    data = bytearray(source.read_bytes())
    data[1] ^= 0xFF  # '\x89HDF' -> '\x89\xb7DF': HDF5 no longer recognises the file
    path.write_bytes(bytes(data))
    return path


def test_detect_by_content_not_by_name(tmp_path, run):
    _, _, _, session, model = run
    assert detect(session) is FileKind.HDF5
    renamed = tmp_path / "session.csv"
    renamed.write_bytes(session.read_bytes())
    assert detect(renamed) is FileKind.HDF5
    # HDF5 files may start with a user block of 512, 1024, 2048, ... bytes
    block = tmp_path / "userblock.bin"
    block.write_bytes(b"\0" * 1024 + HDF5_SIGNATURE + b"\0" * 64)
    assert detect(block) is FileKind.HDF5
    assert detect(model) is FileKind.JSON
    assert detect(random_bytes(tmp_path / "r.h5")) is FileKind.BINARY
    text = tmp_path / "t.csv"
    text.write_bytes(("µ" * 5000).encode())  # a two-byte character cut by the sample's end is still text
    assert detect(text) is FileKind.TEXT
    (tmp_path / "e").write_bytes(b"")
    assert detect(tmp_path / "e") is FileKind.EMPTY
    forc = tmp_path / "f.forc"
    forc.write_text("MicroMag 2900/3900 Data File (Series 0016.002)\n", encoding="utf-8")
    assert detect(forc) is FileKind.MICROMAG


@pytest.mark.parametrize("damage", ["random bytes", "signature lost"])
def test_a_damaged_h5_is_called_what_it_is_by_every_command(tmp_path, run, damage):
    _, _, _, session, model = run
    bad = tmp_path / "bad.h5"
    random_bytes(bad) if damage == "random bytes" else signature_lost(session, bad)
    before = digest(bad)
    calls = [
        ("identify", bad, "--levels", 6),
        ("report", bad, "--out", tmp_path / "rep"),
        ("validate", bad, "--on", session),
        ("validate", session, "--on", bad),
        ("report", session, "--validate", bad, "--out", tmp_path / "rep"),
        ("predict", model, bad),
        ("diagnose", "--fit", bad, "--check", session, "--levels", 6),
    ]
    for args in calls:
        result = rig_here(*args)
        assert_one_line_error(result, "binary data without an HDF5 signature", "not a session although named like one")
        assert "UTF-8" not in result.err and "CSV file" not in result.err
    assert digest(bad) == before and not (tmp_path / "rep").exists()


def test_predict_takes_a_session(run):
    truth, inputs, outputs, session, model = run
    before = digest(session)
    result = rig_here("predict", model, session, "--json")
    assert result.code == 0, result.err
    out = result.json()
    fitted = json.loads(model.read_text())
    expected = model_from_dict(fitted).predict(inputs)  # every applied point, unmeasured ones included
    np.testing.assert_allclose(out["prediction_um"], expected, rtol=0, atol=1e-12)
    measured = np.isfinite(outputs)
    err = expected[measured] - outputs[measured]
    assert (out["n_points"], out["n_measured"]) == (60, 40)
    assert out["rmse_um"] == pytest.approx(np.sqrt(np.mean(err ** 2)), rel=1e-9)
    assert out["max_abs_um"] == pytest.approx(np.abs(err).max(), rel=1e-9)
    assert digest(session) == before


def test_predict_says_what_is_wrong_with_its_files(tmp_path, run):
    _, _, _, session, model = run
    assert_one_line_error(rig_here("predict", session, session), "an HDF5 file (a session), not a JSON model file",
                          "rig validate")
    forc = tmp_path / "f.forc"
    forc.write_text("MicroMag 2900/3900 Data File (Series 0016.002)\n", encoding="utf-8")
    assert_one_line_error(rig_here("predict", model, forc), "a MicroMag FORC data file", "rig import")
    other = json.loads(model.read_text())
    other["output_unit"] = "A m^2"
    (tmp_path / "other.json").write_text(json.dumps(other))
    assert_one_line_error(rig_here("predict", tmp_path / "other.json", session), "records V in and um out")


def test_csv_readers_name_sessions_and_binary_files(tmp_path, run):
    _, _, _, session, _ = run
    out = tmp_path / "o.h5"
    assert_one_line_error(rig_here("import", session, "--out", out), "an HDF5 file (a session?), not a CSV file")
    assert_one_line_error(rig_here("import", random_bytes(tmp_path / "r.csv"), "--out", out),
                          "binary data, not a text CSV file")
    latin = tmp_path / "latin.csv"
    latin.write_bytes("t_s,v_V,deflection_um\n0,1,2 \xb5m\n".encode("latin-1"))
    assert_one_line_error(rig_here("import", latin, "--out", out), "not a UTF-8 text CSV file")
    assert not out.exists() and not os.path.exists(tmp_path / "o.h5")
