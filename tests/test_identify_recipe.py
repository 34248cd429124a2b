"""The session records how it wants to be identified; ``rig identify SESSION`` uses it unless told otherwise.

Real sessions: ``rig acquire`` on the built-in simulated device and its virtual clock, and the
sessions writer directly for a session written without a recipe (as every session was before) and
for recipes ``rig acquire`` would not write."""

import json

import h5py
import pytest

from identify import Excitation, Grid
from sessions import DataFileError, ExcitationRecord, IdentifyRecipe, SessionWriter, Status, read_session

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model
from .sessionkit import write_run

#: L = 6 on the simulated heater's window [0, 6] V: 23 points, 1 s dwells, one reading each.
SMALL = ("--levels", 6, "--dwell", 1, "--readings", 1)


def acquired(path, *extra):
    run = rig_here("acquire", *SMALL, *extra, "--out", path, "--json")
    assert run.code == 0, run.err
    return run.json()


def comparable(result):
    return {k: v for k, v in result.items() if k not in ("seconds", "recipe")}


def test_rig_acquire_stores_the_default_recipe_and_it_reads_back(tmp_path):
    path = tmp_path / "s.h5"
    summary = acquired(path)
    want = {"method": "ls", "levels": 6, "v_min": 0.0, "v_max": 6.0, "effects": [], "thermal_term": True}
    recipe = read_session(path).recipe
    assert isinstance(recipe, IdentifyRecipe)
    assert {k: v for k, v in recipe.to_dict().items() if k != "reason"} == want
    assert "damped" in recipe.reason and "ls" in recipe.reason
    with h5py.File(path, "r") as f:  # where docs/sessions.md says, as any HDF5 tool sees it
        assert json.loads(f.attrs["identify_recipe"]) == recipe.to_dict()
    assert summary["identify_recipe"] == recipe.to_dict()
    text = rig_here("acquire", *SMALL, "--out", tmp_path / "t.h5")
    assert "will use: ls, L=6 on [0, 6], thermal term, no effects" in text.out


@pytest.mark.parametrize("extra, thermal_term, effects", [
    (("--no-thermal-term",), False, []),  # every input on a wall: c_d cannot be identified
    (("--sequence", "damped+check", "--points", 30), True, []),  # no effect assumed: none is documented
    (("--sequence", "random", "--points", 30), True, []),
])
def test_the_default_recipe_follows_what_is_acquired(tmp_path, extra, thermal_term, effects):
    path = tmp_path / "s.h5"
    acquired(path, *extra)
    r = read_session(path).recipe
    assert (r.method, r.levels, r.v_min, r.v_max) == ("ls", 6, 0.0, 6.0)
    assert r.thermal_term is thermal_term and list(r.effects) == effects


def test_rig_identify_fits_as_the_recipe_says_and_keeps_it(tmp_path):
    """The recipe (smooth_nn with the reversible effect, from --identify-with) is not what rig identify does
    by default (ls, no effects): the fit can only come out this way by reading it."""
    path = tmp_path / "s.h5"
    acquired(path, "--identify-with", "smooth_nn:reversible")
    stored = read_session(path).recipe
    assert (stored.method, stored.effects) == ("smooth_nn", ("reversible",))
    assert stored.reason == "rig acquire --identify-with smooth_nn:reversible"
    run = rig_here("identify", path, "--json")
    assert run.code == 0, run.err
    out = run.json()
    assert out["method"] == "smooth_nn" and out["levels"] == 6
    assert [e["name"] for e in out["effects"]] == ["reversible"]
    assert out["name"] == "smooth_nn+reversible"  # the default name says what was fitted
    r = out["recipe"]
    assert r["from"] == dict.fromkeys(("method", "levels", "v_min", "v_max", "thermal_term", "effects"), "session")
    assert (r["method"], r["levels"], r["v_min"], r["v_max"], r["effects"]) == ("smooth_nn", 6, 0.0, 6.0,
                                                                                 ["reversible"])
    assert r["stored"] == stored.to_dict()
    after = read_session(path)
    assert set(after.models) == {"smooth_nn+reversible"} and after.models["smooth_nn+reversible"].method == "smooth_nn"
    assert after.recipe == stored  # storing a model (a rewrite of the file) keeps the recipe
    text = rig_here("identify", path, "--no-store")
    assert text.code == 0, text.err
    assert ("settings from the session's recipe: method smooth_nn, L=6, v_min 0, v_max 6, thermal term, "
            "with reversible") in text.out


def test_explicit_options_win_setting_by_setting(tmp_path):
    path = tmp_path / "s.h5"
    acquired(path, "--identify-with", "smooth_nn:reversible")
    out = rig_here("identify", path, "--method", "ls", "--no-store", "--json").json()
    assert out["method"] == "ls" and [e["name"] for e in out["effects"]] == ["reversible"]
    assert out["recipe"]["from"]["method"] == "option" and out["recipe"]["from"]["effects"] == "session"
    out = rig_here("identify", path, "--with", "creep", "-L", 4, "--no-thermal-term", "--no-store", "--json").json()
    assert out["method"] == "smooth_nn" and [e["name"] for e in out["effects"]] == ["creep"]
    assert out["levels"] == 4 and out["thermal_term"] is False
    src = out["recipe"]["from"]
    assert (src["method"], src["effects"], src["levels"], src["thermal_term"], src["v_min"]) == (
        "session", "option", "option", "option", "session")
    text = rig_here("identify", path, "--method", "ls", "--with", "creep", "--no-store")
    assert text.code == 0, text.err
    assert "from the session's recipe: L=6, v_min 0, v_max 6, thermal term; given: method ls, with creep" in text.out


def test_a_recipe_grid_other_than_the_excitation_grid_is_the_one_fitted(tmp_path):
    """Written by the sessions writer directly: a random run on an L = 10 grid whose recipe asks for
    smooth_nn on L = 6 over [1, 5] V without the thermal term."""
    truth = known_model(6, v_min=0.0, v_max=6.0)
    exc = Excitation.random(Grid(10, 0.0, 6.0), 60, seed=3)
    path = tmp_path / "r.h5"
    recipe = IdentifyRecipe("smooth_nn", 6, 1.0, 5.0, (), False, "a test")
    y = truth.predict(exc.inputs)
    with SessionWriter.create(path, ExcitationRecord.from_excitation(exc), recipe=recipe, fsync_interval_s=None) as w:
        for k, v in enumerate(exc.inputs):
            w.append(float(k), v, y[k], dwell_s=1.0, settled=True)
    out = rig_here("identify", path, "--no-store", "--json").json()
    assert (out["method"], out["levels"], out["v_min"], out["v_max"], out["thermal_term"]) == (
        "smooth_nn", 6, 1.0, 5.0, False)
    assert out["c_d"] == 0.0 and set(out["recipe"]["from"].values()) == {"session"}


def test_a_session_without_a_recipe_behaves_as_before(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=6.0)
    path, _ = write_run(tmp_path / "old.h5", truth, Excitation.damped(truth.grid, thermal_term=True))
    assert read_session(path).recipe is None
    with h5py.File(path, "r") as f:
        assert "identify_recipe" not in f.attrs
    plain = rig_here("identify", path, "--no-store", "--json")
    explicit = rig_here("identify", path, "--method", "ls", "--thermal-term", "--no-store", "--json")
    assert plain.code == 0 and explicit.code == 0, plain.err + explicit.err
    assert "recipe" not in plain.json() and "effects" not in plain.json()
    assert comparable(plain.json()) == comparable(explicit.json())
    assert plain.json()["method"] == "ls" and plain.json()["thermal_term"] is True and plain.json()["levels"] == 6
    text = rig_here("identify", path)
    assert text.code == 0 and "settings" not in text.out and "stored as /models/ls in" in text.out


def test_resuming_keeps_the_recipe(tmp_path):
    exc = Excitation.damped(Grid(4, 0.0, 6.0), thermal_term=True)
    path = tmp_path / "cut.h5"
    recipe = IdentifyRecipe("ls", 4, 0.0, 6.0, (), True, "a test")
    w = SessionWriter.create(path, ExcitationRecord.from_excitation(exc), recipe=recipe, fsync_interval_s=None)
    w.append(0.0, exc.inputs[0], 1.0)
    w.finish(Status.ABORTED, "test")
    w = SessionWriter.reopen(path, fsync_interval_s=None)
    w.finish(Status.ABORTED, "test")
    assert read_session(path).recipe == recipe


def test_a_malformed_or_unknown_recipe_is_one_line(tmp_path):
    path = tmp_path / "s.h5"
    exc = Excitation.damped(Grid(4, 0.0, 6.0), thermal_term=True)
    with SessionWriter.create(path, ExcitationRecord.from_excitation(exc), fsync_interval_s=None,
                              recipe=IdentifyRecipe(method="future_method", reason="a newer rig")) as w:
        for k, v in enumerate(exc.inputs):
            w.append(float(k), v, float(v) ** 2)
    before = digest(path)
    assert read_session(path).recipe.method == "future_method"  # it reads: only using it needs the method
    assert_one_line_error(rig_here("identify", path), "future_method", "does not know", "--method")
    assert digest(path) == before
    assert rig_here("identify", path, "--method", "ls", "--no-store").code == 0
    with h5py.File(path, "r+") as f:
        f.attrs["identify_recipe"] = json.dumps({"method": "ls", "levels": 0})
    with pytest.raises(DataFileError, match="identify_recipe.*levels"):
        read_session(path)
    assert_one_line_error(rig_here("identify", path, "--method", "ls"), "identify_recipe", "levels")


@pytest.mark.parametrize("spec, fragments", [
    ("nope", ["unknown method 'nope'"]),
    ("ls:", ["METHOD[:EFFECT,...]"]),
    ("ls:nope", ["--identify-with", "unknown effect 'nope'"]),
    ("cs:creep", ["no room for effect terms"]),
    ("everett", ["first-order reversal curves"]),
])
def test_bad_identify_with_is_one_line_and_writes_nothing(tmp_path, spec, fragments):
    assert_one_line_error(rig_here("acquire", *SMALL, "--identify-with", spec, "--out", tmp_path / "x.h5"),
                          *fragments)
    assert list(tmp_path.iterdir()) == []


def test_a_square_method_is_refused_for_a_run_that_is_not_square(tmp_path):
    assert_one_line_error(rig_here("acquire", "--sequence", "random", "--points", 20, "--identify-with", "cs",
                                   "--out", tmp_path / "x.h5"), "square damped-oscillation design", "random")
    assert list(tmp_path.iterdir()) == []
