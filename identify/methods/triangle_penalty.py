"""Differences between neighbouring cells of the Preisach triangle.

The roughness penalty of the ``smooth_nn`` method is ``||D mu||_2^2``, where
each row of ``D`` is the difference of the weights of two cells that share
an edge: ``(i, j)`` and ``(i + 1, j)`` (neighbouring alpha bands) or
``(i, j)`` and ``(i, j + 1)`` (neighbouring beta bands), with ``j <= i`` as
in :mod:`identify.grid`.  Diagonal triangles are coupled to the squares
beside them like any other cell: the weights ``mu_ij`` are compared as the
paper defines them (its cells all count as the same size), so a uniform
profile ``mu_ij = const`` has zero roughness.

The triangle is connected, so the penalty vanishes exactly on constant
weight vectors: ``R = D^T D`` has a one-dimensional null space spanned by
``1 / sqrt(n_cells)``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.linalg
import scipy.sparse

from ..grid import Grid


@lru_cache(maxsize=16)
def _difference_matrix(levels: int) -> scipy.sparse.csr_matrix:
    grid = Grid(levels, 0.0, 1.0)
    alpha, beta = grid.cell_alpha, grid.cell_beta
    index = np.full((levels, levels), -1, dtype=np.int64)
    index[alpha, beta] = np.arange(grid.n_cells)
    pairs = []
    # (i, j) - (i + 1, j): every cell but the top alpha band has one above it
    below = alpha < levels - 1
    pairs.append((index[alpha[below], beta[below]], index[alpha[below] + 1, beta[below]]))
    # (i, j) - (i, j + 1): every off-diagonal cell has one to its right
    off = beta < alpha
    pairs.append((index[alpha[off], beta[off]], index[alpha[off], beta[off] + 1]))
    first = np.concatenate([p[0] for p in pairs])
    second = np.concatenate([p[1] for p in pairs])
    edges = first.size
    rows = np.repeat(np.arange(edges), 2)
    cols = np.column_stack([first, second]).ravel()
    vals = np.tile([1.0, -1.0], edges)
    d = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(edges, grid.n_cells))
    d.sort_indices()
    return d


def difference_matrix(grid: Grid) -> scipy.sparse.csr_matrix:
    """``D``, shape ``(n_edges, n_cells)`` with ``n_edges = L (L - 1)``: one row per shared edge."""
    return _difference_matrix(grid.levels)


def roughness_matrix(grid: Grid) -> scipy.sparse.csr_matrix:
    """``R = D^T D``, shape ``(n_cells, n_cells)``: the graph Laplacian of the triangle."""
    d = difference_matrix(grid)
    return (d.T @ d).tocsr()


@lru_cache(maxsize=4)
def _dense_roughness(levels: int) -> np.ndarray:
    r = roughness_matrix(Grid(levels, 0.0, 1.0)).toarray()
    r.flags.writeable = False
    return r


def dense_roughness_matrix(grid: Grid) -> np.ndarray:
    """``R`` as a dense read-only array (cached per number of levels)."""
    return _dense_roughness(grid.levels)


def roughness(grid: Grid, weights: np.ndarray) -> float:
    """``||D mu||_2^2`` of cell weights ``(n_cells,)`` (output units squared)."""
    return float(np.sum((difference_matrix(grid) @ np.asarray(weights, dtype=float)) ** 2))


@lru_cache(maxsize=4)
def _standard_form(levels: int) -> tuple[np.ndarray, np.ndarray]:
    r = _dense_roughness(levels)
    values, vectors = np.linalg.eigh(r)
    # the null space is exactly the constants (connected graph): drop the smallest
    basis = vectors[:, 1:] / np.sqrt(values[1:])
    basis.flags.writeable = False
    values.flags.writeable = False
    return basis, values


def standard_form(grid: Grid) -> np.ndarray:
    """``W`` ``(n_cells, n_cells - 1)`` with ``W^T R W = I`` spanning the non-constant weights.

    Every weight vector is ``mu = c 1 + W b`` with ``||D mu||^2 = ||b||^2``,
    which turns the penalised problem into ridge regression in ``b``.  Dense:
    ``O(n_cells^3)`` once per number of levels (cached).
    """
    return _standard_form(grid.levels)[0]


def grounded_root(grid: Grid) -> np.ndarray:
    """Lower-triangular ``F`` ``(n_cells, n_cells)`` with ``F F^T = (R + 1 1^T / n_cells)^{-1}``.

    ``(R + 1 1^T / n)^{-1}`` is ``W W^T`` (:func:`standard_form`) plus a
    multiple of ``1 1^T``: wherever the constant weight is projected out
    anyway (GCV's unpenalised directions) ``X F`` serves for ``X W`` at
    half the cost of the product (triangular).  Cached per number of levels.
    """
    return _grounded_root(grid.levels)


@lru_cache(maxsize=4)
def _grounded_root(levels: int) -> np.ndarray:
    r = _dense_roughness(levels)
    n = r.shape[0]
    inverse = np.linalg.inv(r + 1.0 / n)
    root = np.asfortranarray(scipy.linalg.cholesky(0.5 * (inverse + inverse.T), lower=True))
    root.flags.writeable = False
    return root
