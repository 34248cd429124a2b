"""A run to a target finds its own dwell: settle replicates, the chi-squared test, superseded points.

Hand-computed cases of :mod:`identify.settling`, and the design on a device whose readings carry the
rest of a first-order transient (``exp(-dwell / tau)`` of each step): the dwell grows until the
replicates show rest, the points of the shorter dwells are dropped, and the posterior is then exactly
the batch posterior of the points kept.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from identify import Grid
from identify.methods.triangle_penalty import dense_roughness_matrix
from identify.regressor import regressor_matrix
from identify.sequential import KIND_CODES, SequentialDesign
from identify.settling import DWELL_STEP, SETTLE_CHECKS, SETTLE_FACTOR, SETTLE_QUANTILE, superseded, unsettled

GRID = Grid(5, 0.0, 6.0)


@pytest.mark.parametrize("m", [1, 3])
def test_the_replicate_test_is_chi_squared_at_its_quantile(m):
    sigma = 0.01
    edge = math.sqrt(chi2.ppf(SETTLE_QUANTILE, m) * 2 * sigma**2 / m)  # every difference the same size
    assert not unsettled(np.full(m, 0.99 * edge), sigma)
    assert unsettled(np.full(m, 1.01 * edge), sigma)
    assert unsettled(np.full(m, -1.01 * edge), sigma)  # a transient of either sign
    assert not unsettled(np.array([]), sigma)


def test_superseded_points_waited_less_than_the_final_dwell():
    waits = np.array([1.0, 1.0, 4.0, 2.0, 2.0, 8.0, 2.0])
    kinds = np.array([0, 0, 2, 0, 1, 2, 0])  # the replicates' long waits do not set the dwell
    assert superseded(waits, kinds).tolist() == [True, True, False, False, False, False, False]
    assert superseded(waits, kinds, 4.0).tolist() == [True, True, False, True, True, False, True]
    assert not superseded(np.array([3.0]), np.array([2])).any()


def _lagging_device(tau_s: float, truth: np.ndarray):
    """Readings of equation (22) with ``exp(-wait / tau)`` of the step from the previous steady output left."""
    state = {"y": None}

    def read(design: SequentialDesign, v: float, wait: float) -> float:
        y = float(design.row_if(v) @ truth)
        y0 = y if state["y"] is None else state["y"]
        state["y"] = y
        return y + (y0 - y) * math.exp(-wait / tau_s)

    return read


def test_the_design_lengthens_its_dwell_until_the_points_are_at_rest():
    rng = np.random.default_rng(3)
    truth = np.concatenate([rng.uniform(0.5, 1.5, GRID.n_cells), [2.0, 0.3]])
    tau, noise = 2.0, 1e-3
    d = SequentialDesign(GRID, noise_um=noise, scale_um=1.0, smooth_um=1.0, dwell_s=1.0, max_dwell_s=600.0)
    read = _lagging_device(tau, truth)
    for _ in range(60):
        v = d.next_input()
        wait = d.next_dwell()
        assert wait == d.dwell_s * (SETTLE_FACTOR if d.proposed == "replicate" else 1.0)
        d.add(v, read(d, v, wait))  # noise-free: only the transient can fail the test
    # the rest of a full-swing step is below a noise level at the dwell found, and was not at half of it
    swing = float(np.ptp(regressor_matrix(GRID, GRID.walls, True) @ truth))
    assert d.lengthened >= 1 and d.dwell_s == 1.0 * DWELL_STEP**d.lengthened
    assert swing * math.exp(-d.dwell_s / DWELL_STEP / tau) > noise
    assert len(d.settle_differences) >= SETTLE_CHECKS
    codes = np.asarray([KIND_CODES[k] for k in d._kinds])
    kept = ~superseded(np.asarray(d.waits), codes, d.dwell_s)
    assert np.array_equal(kept, d.kept) and not kept[0] and kept[-1]
    # the posterior is the batch posterior of the kept points alone
    s = regressor_matrix(GRID, np.asarray(d.inputs), True)[kept]
    nc = GRID.n_cells
    lam = np.zeros((nc + 2, nc + 2))
    lam[:nc, :nc] = dense_roughness_matrix(GRID) + np.eye(nc)
    lam[nc:, nc:] = np.eye(2) / 1e3**2
    post = np.linalg.inv(lam + s.T @ s / d.sigma**2)
    mean = post @ (s.T @ np.asarray(d.outputs)[kept]) / d.sigma**2
    assert np.allclose(d.cov, post, rtol=0, atol=1e-4 * np.abs(post).max())
    assert np.allclose(d.mean, mean, rtol=0, atol=1e-4 * np.abs(mean).max())


def test_a_run_at_rest_keeps_its_first_dwell_and_every_point():
    rng = np.random.default_rng(4)
    truth = np.concatenate([rng.uniform(0.5, 1.5, GRID.n_cells), [2.0, 0.3]])
    d = SequentialDesign(GRID, noise_um=1e-3, scale_um=1.0, smooth_um=1.0, dwell_s=5.0)
    read = _lagging_device(1e-3, truth)
    kinds = []
    for _ in range(30):
        v = d.next_input()
        kinds.append(d.proposed)
        d.add(v, read(d, v, d.next_dwell()))
    assert d.dwell_s == 5.0 and d.lengthened == 0 and d.kept.all()
    # a settle replicate after each of the first design points, until SETTLE_CHECKS stand
    assert kinds[:2 * SETTLE_CHECKS] == ["design", "replicate"] * SETTLE_CHECKS
    assert not d.reached(1.0) or len(d.settle_differences) >= SETTLE_CHECKS
