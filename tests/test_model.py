import json

import numpy as np
import pytest

from identify import Grid, IdentifyError, PreisachModel, damped_oscillation, random_input, regressor_matrix
from identify.model_json import model_from_dict, model_to_dict

from .conftest import known_model


def test_predict_is_equation_22():
    m = known_model(6)
    v = random_input(m.grid, 40, seed=5)
    s = regressor_matrix(m.grid, v, True)
    np.testing.assert_allclose(m.predict(v), s @ m.parameters(True), rtol=0, atol=1e-12)


def test_small_model_by_hand():
    # L = 1 on [0, 1]: u = mu0 + c_d v + mu * s
    m = PreisachModel(Grid(1, 0.0, 1.0), np.array([2.0]), mu0=1.0, c_d=3.0)
    # rise to 0.5 (s = -1/2), fall to 0.25 (s = -5/8), rise to 1 (s = 1)
    np.testing.assert_allclose(m.predict([0.5, 0.25, 1.0]), [1 + 1.5 - 1.0, 1 + 0.75 - 1.25, 1 + 3 + 2])


def test_history_sets_the_starting_memory():
    m = known_model(5)
    v = random_input(m.grid, 30, seed=1)
    whole = m.predict(v)
    np.testing.assert_allclose(m.predict(v[10:], history=v[:10]), whole[10:])
    assert not np.allclose(m.predict(v[10:]), whole[10:])


def test_json_round_trip():
    m = known_model(7)
    d = json.loads(json.dumps(model_to_dict(m)))
    assert len(d["walls"]) == 8 and len(d["density"]) == 7 and all(len(r) == 7 for r in d["density"])
    assert all(d["density"][i][j] == 0 for i in range(7) for j in range(i + 1, 7))
    back = model_from_dict(d)
    assert model_to_dict(back) == model_to_dict(m)
    v = damped_oscillation(m.grid, True)
    np.testing.assert_array_equal(back.predict(v), m.predict(v))


@pytest.mark.parametrize(
    "change,match",
    [
        (lambda d: d.pop("density"), "missing"),
        (lambda d: d.update(walls=[0, 1, 3]), "levels=2|uniformly"),
        (lambda d: d.update(density=[[1.0]]), "2x2"),
        (lambda d: d.update(mu0="abc"), "non-numeric"),
        (lambda d: d.update(format=99), "newer"),
    ],
)
def test_bad_model_dicts(change, match):
    d = model_to_dict(known_model(2))
    change(d)
    with pytest.raises(IdentifyError, match=match):
        model_from_dict(d)
