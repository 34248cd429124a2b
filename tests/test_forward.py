"""The fast forward model: whole sequences and one input at a time."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identify import random_input, regressor_matrix

from .conftest import known_model


@pytest.mark.parametrize("initial", ["negative", "positive"])
def test_predict_matches_the_regressor_with_history(initial):
    m = known_model(9, v_min=-1.0, v_max=2.0)
    v = np.concatenate([random_input(m.grid, 300, seed=2), [5.0, -5.0, 0.5]])  # and saturation
    hist = random_input(m.grid, 20, seed=3)
    s = regressor_matrix(m.grid, v, True, initial, hist)
    np.testing.assert_allclose(m.predict(v, initial, hist), s @ m.parameters(True), atol=1e-11)


@settings(max_examples=30, deadline=None)
@given(xs=st.lists(st.floats(-0.5, 5.5, allow_nan=False), min_size=1, max_size=40))
def test_stepping_state_matches_predict_and_peek_leaves_memory_alone(xs):
    m = known_model(5)
    v = np.array(xs)
    expected = m.predict(v)
    state = m.state()
    for k, x in enumerate(v):
        probe = 5.0 - x  # ask about another input first: must not change the memory
        peeked = state.peek(probe)
        assert state.peek(x) == pytest.approx(expected[k], abs=1e-10)
        assert state.apply(x) == pytest.approx(expected[k], abs=1e-10)
        assert state.output == pytest.approx(expected[k], abs=1e-10)
        assert np.isfinite(peeked)


def test_state_starts_from_history():
    m = known_model(4)
    hist = random_input(m.grid, 10, seed=1)
    v = random_input(m.grid, 10, seed=2)
    state = m.state(history=hist)
    assert state.output == pytest.approx(m.predict(hist)[-1], abs=1e-12)
    np.testing.assert_allclose([state.apply(x) for x in v], m.predict(v, history=hist), atol=1e-11)


@pytest.mark.parametrize("batch", [20_000, 50])  # all rows in one replay; a row or two a replay
def test_predict_many_is_predict_row_by_row_to_the_bit(batch, monkeypatch):
    """The rows are replayed one after another, the memory wiped between them by a fall to the grid's
    bottom: each row's output must be exactly what its own replay gives (the discriminating design's
    secants rely on it to design the same plan)."""
    import identify.forward as forward

    monkeypatch.setattr(forward, "MANY_POINTS", batch)
    m = known_model(7, v_min=-1.0, v_max=2.0)
    rng = np.random.default_rng(5)
    base = random_input(m.grid, 60, seed=4)
    rows = [base,
            base + (rng.random(60) < 0.2) * rng.normal(0.0, 1e-3, 60),  # a secant's small move
            np.where(np.arange(60) < 30, base, 2.5),  # saturates above, then stays
            np.full(60, -1.0),  # never leaves the bottom
            np.round(rng.uniform(-1.5, 2.5, 60), 1)]  # beyond the range and on the walls
    xs = np.array(rows)
    many = m.predict_many(xs)
    assert many.shape == xs.shape
    for row, out in zip(xs, many):
        assert np.array_equal(out, m.predict(row))
