"""The inner cross-validation's shortcuts against its definition: the errors of every fit without the held-out
block and a second block (or a group of blocks), each solved and scored on its own.

:func:`identify.cross_validation._inner_errors` solves the pairs' systems once for both orders, in
batches, and scores a wide design's groups by their summed normal equations; :func:`_normals` forms the
data part once for settings that share their columns.  None of it may change a number beyond rounding."""

from __future__ import annotations

import numpy as np
import pytest

import identify.cross_validation as cvm
from identify.cross_validation import Design, cross_validate, feasible_coefficients, make_blocks, onehot


def _by_definition(ne, gap: np.ndarray, blocks, wide: bool) -> np.ndarray:
    """Each held-out block's inner error, each training fit solved on its own and its error summed point by
    point over the blocks it left out (no Gram shortcut)."""
    nb = blocks.count
    out = np.zeros(nb)
    for b in range(nb):
        rest = np.array([c for c in range(nb) if c != b])
        groups = np.array_split(rest, min(cvm.INNER_FOLDS, rest.size)) if wide else [np.array([c]) for c in rest]
        for grp in groups:
            out_blocks = np.concatenate([[b], grp])
            coef = feasible_coefficients(ne.gram - ne.block_gram[out_blocks].sum(axis=0),
                                         ne.rhs - ne.block_rhs[out_blocks].sum(axis=0), ne.nonneg)
            rows = np.isin(blocks.index, grp)
            out[b] += np.sum((gap[rows] - ne.check[rows] @ coef) ** 2)
    return out


def _case(k: int, m: int = 90, seed: int = 0, nonneg: np.ndarray | None = None):
    rng = np.random.default_rng(seed)
    check = rng.normal(size=(m, k))
    gap = check @ rng.normal(size=k) + 0.3 * rng.normal(size=m)
    return gap, make_blocks([m]), Design(check, nonneg=nonneg)


@pytest.mark.parametrize("nonneg", [None, "some"])
def test_inner_errors_of_a_narrow_design_are_those_of_every_pair_solved_on_its_own(nonneg):
    k = 4
    flags = None if nonneg is None else np.array([True, True, False, False])
    gap, blocks, design = _case(k, nonneg=flags)
    assert blocks.count == 18
    ind = onehot(blocks)
    ne = cvm._normal(design, gap, ind, None, 1.0)
    got = cvm._inner_errors(ne, ind @ (gap * gap))
    np.testing.assert_allclose(got, _by_definition(ne, gap, blocks, wide=False), rtol=1e-10)


def test_inner_errors_of_a_wide_design_are_those_of_every_group_solved_on_its_own(monkeypatch):
    monkeypatch.setattr(cvm, "WIDE", 3)  # a 5-column design counts as wide: groups of blocks are left out
    gap, blocks, design = _case(5, seed=1)
    ind = onehot(blocks)
    ne = cvm._normal(design, gap, ind, None, 1.0)
    got = cvm._inner_errors(ne, ind @ (gap * gap))
    np.testing.assert_allclose(got, _by_definition(ne, gap, blocks, wide=True), rtol=1e-10)


@pytest.mark.parametrize("wide", [False, True])
def test_inner_errors_do_not_depend_on_the_batch_size_nor_on_a_reused_scratch(monkeypatch, wide):
    if wide:
        monkeypatch.setattr(cvm, "WIDE", 3)
    gap, blocks, design = _case(4, seed=2)
    ind = onehot(blocks)
    gg = ind @ (gap * gap)
    ne = cvm._normal(design, gap, ind, None, 1.0)
    whole = cvm._inner_errors(ne, gg)
    monkeypatch.setattr(cvm, "BATCH_ENTRIES", 40)  # two systems a batch: one held-out block's at least
    np.testing.assert_array_equal(cvm._inner_errors(ne, gg), whole)
    scratch, shared = np.full(7, np.nan), {}  # too small: replaced; then the same again with what it keeps
    np.testing.assert_array_equal(cvm._inner_errors(ne, gg, scratch, shared), whole)
    np.testing.assert_array_equal(cvm._inner_errors(ne, gg, np.full(10_000, np.nan), shared), whole)
    assert bool(shared) == wide


def test_settings_that_share_their_columns_share_the_data_part_and_nothing_else():
    rng = np.random.default_rng(3)
    m, k = 60, 3
    check, fit = rng.normal(size=(m, k)), rng.normal(size=(20, k))
    rough = np.diag([0.0, 1.0, 2.0])
    gap, residual = rng.normal(size=m), rng.normal(size=20)
    shared = [Design(check, fit, rough, w) for w in (0.1, 1.0, 10.0)]
    apart = [Design(check.copy(), fit.copy(), rough, w) for w in (0.1, 1.0, 10.0)]
    blocks = make_blocks([m])
    ind = onehot(blocks)
    one, each = cvm._normals(shared, gap, ind, residual, 0.5), cvm._normals(apart, gap, ind, residual, 0.5)
    assert one[0].block_gram is one[2].block_gram and each[0].block_gram is not each[2].block_gram
    for a, b in zip(one, each):
        np.testing.assert_array_equal(a.gram, b.gram)
        np.testing.assert_array_equal(a.block_gram, b.block_gram)
    assert not np.array_equal(one[0].gram, one[2].gram)  # the penalty weight still tells them apart
    x, y = cross_validate(gap, blocks, shared, residual, 0.5), cross_validate(gap, blocks, apart, residual, 0.5)
    np.testing.assert_array_equal(x.prediction, y.prediction)
    np.testing.assert_array_equal(x.chosen, y.chosen)


def test_the_ridge_added_in_place_equals_the_ridge_added_as_a_matrix():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(3, 10, 4))
    gram, rhs = a.transpose(0, 2, 1) @ a, rng.normal(size=(3, 4))
    ridge = cvm.RIDGE * np.trace(gram, axis1=-2, axis2=-1) / 4 + 1e-300
    by_matrix = np.linalg.solve(gram + ridge[:, None, None] * np.eye(4), rhs[..., None])[..., 0]
    kept = gram.copy()
    np.testing.assert_array_equal(cvm._ridged(gram, rhs)[2], by_matrix)
    np.testing.assert_array_equal(gram, kept)  # not overwritten unless asked
    np.testing.assert_array_equal(cvm._ridged(gram, rhs, overwrite=True)[2], by_matrix)
