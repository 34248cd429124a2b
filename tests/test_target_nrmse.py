"""``rig acquire --target-nrmse X``: a run that chooses its set-points and stops at a predicted error.

* :class:`identify.sequential.SequentialDesign`: the rank-one updates give the batch posterior of the
  points so far (hand-checkable linear algebra), replicates estimate the noise, check points calibrate;
* the command runs the design on the simulated device, ends complete with fewer points than its most,
  the session is not partial, records the predicted error per point and the recipe, and ``rig identify``
  fits it; bad input is one line and exit 2 with nothing written; such a run is not resumed.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from identify import Grid
from identify.methods.triangle_penalty import dense_roughness_matrix
from identify.regressor import regressor_matrix
from identify.sequential import CHECK_EVERY, MIN_CHECKS, REPLICATE_EVERY, SequentialDesign
from sessions import ADAPTIVE_KIND, read_session

from .acquirekit import refused_before_writing, virtual_sim_config
from .cli import assert_one_line_error, rig_here

GRID = Grid(5, 0.0, 6.0)


def _design(**kw) -> SequentialDesign:
    return SequentialDesign(GRID, noise_um=kw.pop("noise_um", 0.01), scale_um=0.5, smooth_um=0.3, **kw)


def test_rank_one_updates_equal_the_batch_posterior():
    d = _design()
    rng = np.random.default_rng(0)
    truth = np.concatenate([rng.uniform(0, 1, GRID.n_cells), [2.0, -1.5]])
    for _ in range(23):
        v = d.next_input()
        d.add(v, float(d.row_if(v) @ truth) + 0.01 * rng.standard_normal())
    s = regressor_matrix(GRID, np.asarray(d.inputs), True)
    nc = GRID.n_cells
    lam = np.zeros((nc + 2, nc + 2))
    lam[:nc, :nc] = dense_roughness_matrix(GRID) / 0.3**2 + np.eye(nc) / 0.5**2
    lam[nc:, nc:] = np.eye(2) / 1e3**2
    sigma = d.noise_um  # no replicate shows more noise than assumed here (few pairs)
    post = np.linalg.inv(lam + s.T @ s / sigma**2)
    mean = post @ (s.T @ np.asarray(d.outputs)) / sigma**2
    scale = np.abs(post).max()
    assert np.allclose(d.cov, post, rtol=0, atol=1e-5 * scale)
    assert np.allclose(d.mean, mean, rtol=0, atol=1e-5 * np.abs(mean).max())
    expected = np.einsum("ij,jk,ik->i", d.check, post, d.check)
    assert np.allclose(d.check_var, expected, rtol=0, atol=1e-5 * expected.max())


def test_replicates_and_check_points_come_when_documented():
    d = _design()
    kinds = []
    for _ in range(2 * REPLICATE_EVERY + 1):
        v = d.next_input()
        kinds.append(d.proposed)
        if d.proposed == "replicate":
            assert v == d.inputs[-1]
        d.add(v, 1.0)
    assert kinds[REPLICATE_EVERY] == "replicate" and kinds[2 * REPLICATE_EVERY] == "replicate"
    assert kinds[CHECK_EVERY - 1] == "check"
    assert d.pairs == [0.0, 0.0]  # the same reading twice: no noise seen
    assert d.calibration != 1.0 or len(d.errors) < MIN_CHECKS


def test_noise_shown_by_replicates_replaces_a_smaller_assumed_one():
    d = _design(noise_um=1e-3)
    rng = np.random.default_rng(1)
    for _ in range(4 * REPLICATE_EVERY + 1):
        v = d.next_input()
        d.add(v, 0.1 * rng.standard_normal())
    assert len(d.pairs) >= 3
    assert d.sigma == pytest.approx(math.sqrt(np.mean(np.square(d.pairs)) / 2))
    assert d.sigma > 1e-3


def test_a_run_to_a_target_stops_complete_and_is_identified(tmp_path):
    cfg, out = virtual_sim_config(tmp_path, 5, 0.5), tmp_path / "to.h5"
    r = rig_here("acquire", "--config", cfg, "--target-nrmse", 0.02, "--dwell", 5, "--readings", 1,
                 "--out", out, "--json")
    assert r.code == 0, r.err
    summary = r.json()
    assert summary["excitation"] == ADAPTIVE_KIND and summary["status"] == "complete"
    assert summary["target_reached"] and summary["predicted_nrmse"] <= 0.02
    assert 20 <= summary["n_applied"] < summary["n_points"]
    assert "ended: target reached" in r.err
    s = read_session(out)
    assert not s.is_partial
    assert np.all(np.diff(s.extra["predicted_nrmse"][20:]) < np.inf)  # recorded with every point
    assert set(np.unique(s.extra["point_kind"])) <= {0, 1, 2}
    assert s.recipe.method == "smooth_nn"
    ident = rig_here("identify", out, "--json")
    assert ident.code == 0, ident.err
    resumed = rig_here("acquire", "--resume", out)
    assert_one_line_error(resumed, "nothing to resume")


def test_a_rig_time_cap_ends_the_run_before_the_target(tmp_path):
    cfg, out = virtual_sim_config(tmp_path, 5, 0.5), tmp_path / "cap.h5"
    r = rig_here("acquire", "--config", cfg, "--target-nrmse", 0.0005, "--rig-time", 200, "--dwell", 5,
                 "--out", out, "--json")
    assert r.code == 0, r.err
    summary = r.json()
    assert not summary["target_reached"] and summary["rig_time_s"] <= 200.0
    assert "ended: rig-time cap" in r.err


@pytest.mark.parametrize("args, message", [
    (["--target-nrmse", "1e-7"], "below the noise floor"),
    (["--target-nrmse", "-0.1"], "positive"),
    (["--target-nrmse", "0.01", "--measure", "30"], "--measure contradicts"),
    (["--target-nrmse", "0.01", "--sequence", "random"], "--sequence random contradicts"),
    (["--target-nrmse", "0.01", "--rig-time", "-5"], "--rig-time must be a positive"),
])
def test_target_bad_input_exits_2_and_writes_nothing(tmp_path, args, message):
    refused_before_writing(virtual_sim_config(tmp_path, 5, 0.5), tmp_path, args, message)


def test_a_run_to_a_target_finds_its_dwell_on_a_slow_beam(tmp_path):
    """Time constant 3 s, no --dwell: the run starts at 1 s, lengthens its dwell as its settle replicates
    demand, says so, and the session hands rig identify only the points measured at the final dwell."""
    from identify.settling import SUPERSEDED_SHARE

    cfg, out = virtual_sim_config(tmp_path, 5, 3.0), tmp_path / "slow.h5"
    r = rig_here("acquire", "--config", cfg, "--target-nrmse", 0.02, "--readings", 1, "--out", out, "--json")
    assert r.code == 0, r.err
    assert "waiting 1 s at first" in r.err and "the dwell is now 2 s" in r.err
    s = read_session(out)
    kinds = s.extra["point_kind"]
    final = float(s.samples["dwell_s"][kinds != 2].max())
    assert final >= 4.0  # 1 s is a third of the time constant: not at rest
    gone = s.superseded
    assert gone.any() and not gone[-1]
    assert np.array_equal(gone, s.samples["dwell_s"] < SUPERSEDED_SHARE * final)
    assert np.isnan(s.outputs[gone]).all() and np.isfinite(s.outputs[~gone]).all()
    assert s.excitation.extra["first_dwell_s"] == 1.0
    summary = r.json()
    assert summary["final_dwell_s"] == final and summary["superseded_points"] == int(gone.sum())
    assert np.array_equal(s.extra["asked_dwell_s"][kinds != 2], s.samples["dwell_s"][kinds != 2])  # no pause
    # a pause lengthens a point's recorded wait, not the wait the run asked: the same points stay superseded
    paused = s.samples.copy()
    paused["dwell_s"][int(np.flatnonzero(kinds == 0)[1])] = 100 * final
    s_paused = dataclasses.replace(s, samples=paused)
    assert np.array_equal(s_paused.superseded, gone) and s_paused.final_dwell_s == final


def test_a_first_dwell_above_the_longest_is_refused(tmp_path):
    refused_before_writing(virtual_sim_config(tmp_path, 5, 0.5), tmp_path, ["--target-nrmse", "0.01", "--dwell",
                                                                            "601"], "at most 600 s")
