"""Held-out scores: blocked cross-validation over the check data, and the block bootstrap.

The gap diagnosis (:mod:`identify.diagnosis`) scores its candidates with it, and a stored model's per-run
effects are re-estimated held out with it on a run they do not know (:mod:`identify.effects.nuisance`):
it stands below both.

**Why cross-validation.**  A candidate's coefficients (and its nonlinear
setting) must be estimated somewhere.  The identification runs often
cannot tell them apart from the density -- the damped-oscillation design
is square, so the base model absorbs almost anything those runs contain --
and per-run nuisance (a drift) exists only in the run it acts on.  So the
coefficients are estimated on the check data, and every check point is
scored by a fit that did not see it: the check runs are cut into
contiguous time blocks; for each block, the coefficients (for every
setting on the candidate's grid, the setting with the smallest training
error chosen) are fitted on all *other* blocks and predict the held-out
block.  Blocks are contiguous in time because the errors of neighbouring
points are correlated (a transient after a reversal spans several points);
a drift in a held-out block is interpolated from the blocks around it.

**Joint with the base model.**  The columns fitted here are the effective
columns ``E = C_check - x_F pinv(X_F) C_fit``: the effect on the check
points minus what the base fit would have absorbed of it on the
identification points (:mod:`identify.diagnosis.base`).  Fitting ``E``
to the base model's check residual is the least-squares fit of the
candidate together with a base model re-identified on the identification
data with the candidate included -- the density is never fitted to check
data.

**Uncertainty.**  Scores are resampled by a stratified block bootstrap:
each check run's blocks are drawn with replacement, the same draws for the
baseline and every candidate (paired), so differences between candidates
have honest standard errors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .methods.nnls import nnls_free

#: Aim for this many blocks per check run.
TARGET_BLOCKS = 40
#: A block holds at least this many scored points.
MIN_BLOCK_POINTS = 5
#: Ridge weight relative to the mean diagonal of the Gram matrix of unit-rms columns: shrinks
#: only the directions the training data hardly see (a drift spline over a time window whose
#: training points all sit in saturation, where the ambient sensitivity is zero).
RIDGE = 1e-6
#: Bootstrap resamples.
N_BOOT = 2000
#: A design with more columns than this (a fine grid's cells) chooses its setting by an inner
#: cross-validation over :data:`INNER_FOLDS` contiguous groups of the remaining blocks, not each block in
#: turn: hundreds of columns would take minutes.  Narrower designs leave each block out, as the outer
#: loop does: for a drift, leaving out groups of blocks (a quarter of an hour of the run) chose smoothings
#: that interpolate a single block's gap badly (a drift's held-out shrink fell from 0.30 to -0.02).
WIDE = 60
INNER_FOLDS = 10
#: Most matrix entries of the narrow inner systems solved in one batch (8 bytes each).
BATCH_ENTRIES = 2_000_000



@dataclass(frozen=True)
class Blocks:
    """Contiguous time blocks of the scored check points.

    ``index`` ``(m,)`` block of every scored point (blocks numbered run
    by run); ``run`` ``(B,)`` the check run each block belongs to;
    ``size`` ``(B,)`` points per block.
    """

    index: np.ndarray
    run: np.ndarray
    size: np.ndarray

    @property
    def count(self) -> int:
        return int(self.size.size)

    def per_run(self, run: int) -> int:
        return int(np.sum(self.run == run))


def make_blocks(points_per_run: list[int]) -> Blocks:
    """About :data:`TARGET_BLOCKS` contiguous blocks per run, at least :data:`MIN_BLOCK_POINTS` points each."""
    index, runs, sizes = [], [], []
    first = 0
    for r, m in enumerate(points_per_run):
        nb = max(1, min(TARGET_BLOCKS, m // MIN_BLOCK_POINTS))
        edges = np.linspace(0, m, nb + 1).round().astype(int)
        for b in range(nb):
            index.append(np.full(edges[b + 1] - edges[b], first + b))
            runs.append(r)
            sizes.append(edges[b + 1] - edges[b])
        first += nb
    return Blocks(np.concatenate(index) if index else np.zeros(0, int), np.asarray(runs), np.asarray(sizes))


def _ridged(gram: np.ndarray, rhs: np.ndarray, overwrite: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The normal equations with :data:`RIDGE` times the mean diagonal added, the right-hand side (as
    arrays), and their unconstrained solution (zeros when there is no coefficient).  ``overwrite``: the
    ridge may be added to ``gram`` itself (a temporary of the caller's, float and writable)."""
    gram = np.asarray(gram, dtype=float)
    rhs = np.asarray(rhs, dtype=float)
    k = rhs.shape[-1]
    if k == 0:
        return gram, rhs, np.zeros(rhs.shape)
    ridge = RIDGE * np.trace(gram, axis1=-2, axis2=-1) / k + 1e-300
    g = gram if overwrite else gram.copy()  # the ridge added on the diagonal (ridge * I costs a batch of matrices)
    diagonal = np.arange(k)
    g[..., diagonal, diagonal] += ridge[..., None]
    return g, rhs, np.linalg.solve(g, rhs[..., None])[..., 0]


def solve_coefficients(gram: np.ndarray, rhs: np.ndarray, nonneg: np.ndarray) -> np.ndarray:
    """``argmin b^T G b - 2 b^T r`` (least squares from its normal equations), ``b[j] >= 0`` where
    ``nonneg[j]``; batched over leading axes of ``gram`` ``(..., k, k)`` and ``rhs`` ``(..., k)``.

    A ridge of :data:`RIDGE` times the mean diagonal keeps directions the
    data hardly see at zero.  Constrained coefficients: a single one is
    clipped at zero (exact for one coefficient); several are handled by an
    active-set pass, one system at a time.
    """
    g, rhs, coef = _ridged(gram, rhs)
    k = rhs.shape[-1]
    if k == 0:
        return coef
    nonneg = np.asarray(nonneg, dtype=bool)
    if not nonneg.any():
        return coef
    if k == 1:
        return np.maximum(coef, 0.0)
    if nonneg.sum() == 1:  # one constrained coefficient (a lagging fraction): re-solve the violators without it
        j = int(np.flatnonzero(nonneg)[0])
        bad = coef[..., j] < 0
        if bad.any():
            keep = np.flatnonzero(np.arange(k) != j)
            sub = np.linalg.solve(g[bad][:, keep][:, :, keep], rhs[bad][:, keep][..., None])[..., 0]
            fixed = np.zeros((int(bad.sum()), k))
            fixed[:, keep] = sub
            coef[bad] = fixed
        return coef
    # several constrained coefficients: NNLS on the Cholesky factor, one system at a time
    order = np.concatenate([np.flatnonzero(nonneg), np.flatnonzero(~nonneg)])
    flat_g, flat_r = g.reshape(-1, k, k), rhs.reshape(-1, k)
    out = coef.reshape(-1, k)
    for i in range(out.shape[0]):
        if not (out[i][nonneg] < 0).any():
            continue
        chol = np.linalg.cholesky(flat_g[i][np.ix_(order, order)])
        target = np.linalg.solve(chol, flat_r[i][order])
        sol, _ = nnls_free(chol.T, target, int(nonneg.sum()))
        out[i, order] = sol
    return out.reshape(coef.shape)


def feasible_coefficients(gram: np.ndarray, rhs: np.ndarray, nonneg: np.ndarray, overwrite: bool = False
                          ) -> np.ndarray:
    """A feasible, nearly optimal solution of :func:`solve_coefficients`' problem for a whole batch at once.

    The unconstrained solution, then, while any constrained coefficient is negative, those coefficients
    are fixed at zero and the rest re-solved (every system of the batch in one call).  The coefficients
    it keeps are optimal for their set; unlike an active-set method it never frees a coefficient again,
    so the error is an upper bound of the exact one -- close enough to *choose* a setting (a spectrum's
    sign) in the inner cross-validation, where an exact solve per system and block pair cost minutes,
    and honest where an unconstrained one is not: without the constraint the two signs of a
    relaxation spectrum fit alike, and the choice between them was a coin toss.  ``overwrite``: ``gram``
    is the caller's temporary, and the ridge may be added to it in place.
    """
    g, rhs, coef = _ridged(gram, rhs, overwrite)
    k = rhs.shape[-1]
    nonneg = np.asarray(nonneg, dtype=bool)
    if k == 0 or not nonneg.any():
        return coef
    shape = coef.shape
    coef, g, rhs = coef.reshape(-1, k), np.broadcast_to(g, shape + (k,)).reshape(-1, k, k), rhs.reshape(-1, k)
    kept = np.ones(coef.shape, bool)
    for _ in range(int(nonneg.sum())):
        bad = (coef < 0) & nonneg & kept
        rows = np.flatnonzero(bad.any(axis=1))  # re-solve only the systems that still break a sign
        if not rows.size:
            break
        kept[rows] &= ~bad[rows]
        kr = kept[rows]
        gm = np.where(kr[:, :, None] & kr[:, None, :], g[rows], 0.0) + np.eye(k) * (~kr)[:, None, :]
        coef[rows] = np.linalg.solve(gm, np.where(kr, rhs[rows], 0.0)[..., None])[..., 0]
    return np.where(kept, coef, 0.0).reshape(shape)


@dataclass(frozen=True, eq=False)
class Design:
    """One setting of a candidate in the joint fit.

    ``check`` ``(m, k)``: the effective columns at the scored check points;
    ``fit`` ``(m_fit, k)`` or None: what the base fit cannot absorb of them at
    the identification points; ``roughness`` ``(k, k)`` or None: a penalty
    ``b^T R b`` on the coefficients ``b`` (in the columns' own units), added
    with weight ``smoothing`` relative to the data (``smoothing = 1``: the
    penalty's mean diagonal equals the data Gram matrix's); ``nonneg`` ``(k,)``.
    """

    check: np.ndarray
    fit: np.ndarray | None = None
    roughness: np.ndarray | None = None
    smoothing: float = 0.0
    nonneg: np.ndarray | None = None
    #: Further penalties on blocks of the columns, each ``(columns, R, smoothing)`` weighed like ``roughness``
    #: against the data Gram matrix of its own columns (two candidates fitted together keep their own).
    blocks: tuple = ()


def joint_design(a: Design, b: Design) -> Design:
    """Two candidates' designs fitted together: their columns side by side, each keeping its penalty."""
    ka, kb = a.check.shape[1], b.check.shape[1]
    fit = None
    if a.fit is not None or b.fit is not None:
        fa = a.fit if a.fit is not None else np.zeros((b.fit.shape[0], ka))
        fb = b.fit if b.fit is not None else np.zeros((a.fit.shape[0], kb))
        fit = np.hstack([fa, fb])
    blocks = []
    for d, offset, k in ((a, 0, ka), (b, ka, kb)):
        if d.roughness is not None and d.smoothing > 0:
            blocks.append((offset + np.arange(k), np.asarray(d.roughness, dtype=float), float(d.smoothing)))
        for idx, r, w in d.blocks:
            blocks.append((offset + np.asarray(idx), r, w))
    nonneg = np.concatenate([np.zeros(ka, bool) if a.nonneg is None else np.asarray(a.nonneg, bool),
                             np.zeros(kb, bool) if b.nonneg is None else np.asarray(b.nonneg, bool)])
    return Design(np.hstack([a.check, b.check]), fit, None, 0.0, nonneg, tuple(blocks))


@dataclass(frozen=True)
class CrossValidation:
    """The held-out prediction of the gap ``(m,)``; the setting chosen for each block ``(B,)``;
    and, for reporting, the setting chosen by cross-validation over all blocks with its
    coefficients ``(k,)`` fitted on all the data."""

    prediction: np.ndarray
    chosen: np.ndarray
    full_setting: int
    full_coef: np.ndarray


@dataclass(frozen=True, eq=False)
class _Normal:
    """Normal equations of one setting: totals, per-block parts, and the block outputs."""

    gram: np.ndarray        # (k, k) all data + penalty
    rhs: np.ndarray         # (k,)
    block_gram: np.ndarray  # (B, k, k) check part of each block
    block_rhs: np.ndarray   # (B, k)
    check: np.ndarray       # (m, k) normalised check columns
    scale: np.ndarray       # (k,) column scales
    nonneg: np.ndarray


def _data_part(design: Design, gap: np.ndarray, ind: np.ndarray, fit_residual, fit_weight: float) -> tuple:
    """What a design's normal equations owe to its columns alone, before any penalty: the normalised check
    columns ``(m, k)``, the column scales ``(k,)``, the data Gram matrix and right-hand side, and each
    block's part of them.  Settings that differ only in their penalty (a drift's roughness weights) share
    it (:func:`_normals`)."""
    e = np.asarray(design.check, dtype=float)
    a = None if design.fit is None or fit_residual is None else np.asarray(design.fit, dtype=float)
    sq, n = np.sum(e * e, axis=0), e.shape[0]
    if a is not None:
        sq, n = sq + np.sum(a * a, axis=0), n + a.shape[0]
    scale = np.where(sq > 0, np.sqrt(sq / max(n, 1)), 1.0)  # unit-rms columns: the ridge treats all alike
    e = e / scale
    gram, rhs = e.T @ e, e.T @ gap
    if a is not None:
        a = a / scale
        gram = gram + fit_weight * (a.T @ a)
        rhs = rhs + fit_weight * (a.T @ fit_residual)
    k = e.shape[1]
    members = [np.flatnonzero(ind[b]) for b in range(ind.shape[0])]
    block_gram = np.stack([e[r].T @ e[r] for r in members]) if members else np.zeros((0, k, k))
    block_rhs = np.stack([e[r].T @ gap[r] for r in members]) if members else np.zeros((0, k))
    return e, scale, gram, rhs, block_gram, block_rhs


def _normal(design: Design, gap: np.ndarray, ind: np.ndarray, fit_residual, fit_weight: float,
            data: tuple | None = None) -> _Normal:
    """``design``'s normal equations; ``data``: its :func:`_data_part` when already computed."""
    e, scale, gram, rhs, block_gram, block_rhs = data or _data_part(design, gap, ind, fit_residual, fit_weight)
    k = e.shape[1]
    for idx, r, w in design.blocks:
        idx = np.asarray(idx)
        p = np.asarray(r, dtype=float) / np.outer(scale[idx], scale[idx])
        sub = gram[np.ix_(idx, idx)]
        gram = gram.copy()
        gram[np.ix_(idx, idx)] = sub + w * p * np.trace(sub) / max(np.trace(p), 1e-300)
    if design.roughness is not None and design.smoothing > 0:
        p = np.asarray(design.roughness, dtype=float) / np.outer(scale, scale)
        gram = gram + design.smoothing * p * np.trace(gram) / max(np.trace(p), 1e-300)
    nonneg = np.zeros(k, bool) if design.nonneg is None else np.asarray(design.nonneg, dtype=bool)
    return _Normal(gram, rhs, block_gram, block_rhs, e, scale, nonneg)


def _normals(designs, gap: np.ndarray, ind: np.ndarray, fit_residual, fit_weight: float) -> list[_Normal]:
    """:func:`_normal` of each design, the data part computed once for designs that share their column
    arrays (the same ``check`` and ``fit`` objects: settings that differ only in a penalty)."""
    done: dict[tuple[int, int], tuple] = {}
    out = []
    for d in designs:
        key = (id(d.check), id(d.fit))
        if key not in done:
            done[key] = _data_part(d, gap, ind, fit_residual, fit_weight)
        out.append(_normal(d, gap, ind, fit_residual, fit_weight, done[key]))
    return out


def _block_sse(ne: _Normal, gg: np.ndarray, coef: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """Squared error of ``coef`` ``(..., k)`` on the given blocks (same leading shape)."""
    r = ne.block_rhs[blocks]
    g = ne.block_gram[blocks]
    return gg[blocks] - 2.0 * np.sum(coef * r, axis=-1) + np.einsum("...i,...ij,...j->...", coef, g, coef)


def _group_parts(ne: _Normal, gg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A wide design's inner folds: ``group`` ``(B, F)``, the ``f``-th group of blocks left out beside held-out
    block ``b`` (an index into the rest), and each group's summed block Gram matrices, right-hand sides and
    squared gaps.  The same for every setting that shares the design's data part."""
    nb = ne.block_rhs.shape[0]
    others = np.arange(nb)
    sums: dict[tuple[int, ...], int] = {}  # a group's index in the parts below, shared by the held-out blocks
    part_g, part_r, part_gg = [], [], []
    group = np.zeros((nb, min(INNER_FOLDS, nb - 1)), int)
    for b in range(nb):
        rest = others[others != b]
        for f, grp in enumerate(np.array_split(rest, min(INNER_FOLDS, rest.size))):
            key = tuple(grp)
            if key not in sums:
                sums[key] = len(part_g)
                part_g.append(ne.block_gram[grp].sum(axis=0))
                part_r.append(ne.block_rhs[grp].sum(axis=0))
                part_gg.append(gg[grp].sum())
            group[b, f] = sums[key]
    return group, np.stack(part_g), np.stack(part_r), np.asarray(part_gg)


def _inner_errors(ne: _Normal, gg: np.ndarray, scratch: np.ndarray | None = None, shared: dict | None = None
                  ) -> np.ndarray:
    """The inner cross-validation's squared error ``(B,)`` of one setting for each held-out block ``b``: the
    other blocks' errors, each left out in turn (or :data:`INNER_FOLDS` groups of them for a wide design)
    from the fit without ``b``.

    A narrow design leaves out every pair of blocks, and the fit without ``b`` and ``c`` is the same for
    held-out ``b`` (scored on ``c``) and held-out ``c`` (scored on ``b``): each pair's system is solved
    once, ``(G - G_b) - G_c`` for ``b < c`` (for ``b > c`` it differs from the per-block order only by
    rounding), in batches of at most :data:`BATCH_ENTRIES` matrix entries; the errors of all pairs are then
    read from each block's normal equations, one product per block (``(B, B, k)`` coefficients kept).  A
    wide design's fits without ``b`` and a group are all solved in such batches too, and each is scored
    on the group as a whole (the group's summed normal equations: one quadratic form, not one per block).
    The batches are formed in ``scratch`` (a float array, replaced when too small; reused from setting to
    setting: fresh memory for every batch cost as much as solving it), and a
    wide design's groups are kept in ``shared`` for the settings that share its data part.
    """
    nb, k = ne.block_rhs.shape
    if nb == 0:
        return np.zeros(0)
    left = ne.gram - ne.block_gram  # (B, k, k): the fit without b, before a second block is taken out
    left_r = ne.rhs - ne.block_rhs
    step = max(1, BATCH_ENTRIES // max(1, k * k))
    systems = nb * (nb - 1) // 2 if k <= WIDE else nb * min(INNER_FOLDS, nb - 1)
    need = min(systems, max(step, nb)) * k * k  # a batch holds at least one held-out block's systems
    if scratch is None or scratch.size < need:
        scratch = np.empty(need)
    if k <= WIDE:  # leave each remaining block out in turn
        coef = np.zeros((nb, nb, k))  # [b, c]: fitted without blocks b and c (b < c here, mirrored below)
        b = 0
        while b < nb - 1:  # a batch: the pairs (b, c > b) of consecutive b, at least one b's
            last, size = b, nb - 1 - b
            while last + 1 < nb - 1 and size + nb - 2 - last <= step:
                last += 1
                size += nb - 1 - last
            m = scratch[: size * k * k].reshape(size, k, k)
            r = np.empty((size, k))
            at = 0
            for h in range(b, last + 1):  # (G - G_h) - G_c for every c > h: views, no gathered copies
                np.subtract(left[h], ne.block_gram[h + 1:], out=m[at:at + nb - 1 - h])
                np.subtract(left_r[h], ne.block_rhs[h + 1:], out=r[at:at + nb - 1 - h])
                at += nb - 1 - h
            solved = feasible_coefficients(m, r, ne.nonneg, overwrite=True)
            at = 0
            for h in range(b, last + 1):
                coef[h, h + 1:] = solved[at:at + nb - 1 - h]
                at += nb - 1 - h
            b = last + 1
        coef += coef.transpose(1, 0, 2)  # the fit without b and c serves both (zeros elsewhere: exact)
        # sse[c, b]: the fit without b and c scored on block c, b = c contributing nothing
        by_c = coef.transpose(1, 0, 2)
        sse = gg[:, None] + np.sum(by_c * (np.matmul(by_c, ne.block_gram) - 2.0 * ne.block_rhs[:, None, :]), axis=-1)
        sse[np.diag_indices(nb)] = 0.0
        return sse.sum(axis=0)
    key = id(ne.block_gram)
    if shared is None or key not in shared:
        parts = _group_parts(ne, gg)
        if shared is not None:
            shared[key] = (ne.block_gram, parts)  # the array kept alive with its id
    else:
        parts = shared[key][1]
    group, part_g, part_r, part_gg = parts
    folds = group.shape[1]
    coef = np.zeros(group.shape + (k,))
    per = max(1, step // folds)  # held-out blocks a batch
    for start in range(0, nb, per):
        rows = slice(start, min(nb, start + per))
        n = rows.stop - start
        m = scratch[: n * folds * k * k].reshape(n, folds, k, k)
        np.take(part_g, group[rows], axis=0, out=m, mode="clip")
        np.subtract(left[rows, None], m, out=m)
        coef[rows] = feasible_coefficients(m, left_r[rows, None] - part_r[group[rows]], ne.nonneg, overwrite=True)
    quad = np.zeros(group.shape)  # coef^T G_g coef, one product per group (no batch of its Gram matrices)
    for g in range(part_gg.size):
        mine = group == g
        quad[mine] = np.sum(coef[mine] * (coef[mine] @ part_g[g]), axis=-1)
    sse = part_gg[group] + quad - 2.0 * np.sum(coef * part_r[group], axis=-1)
    return sse.sum(axis=1)


def cross_validate(
    gap: np.ndarray,
    blocks: Blocks,
    designs: list[Design],
    fit_residual: np.ndarray | None = None,
    fit_weight: float = 1.0,
) -> CrossValidation:
    """Leave-one-block-out predictions of ``gap`` ``(m,)`` by a candidate with settings ``designs``.

    ``fit_residual`` ``(m_fit,)`` is the base fit's residual on the
    identification points: with each design's ``fit`` columns it is the
    identification part of the joint fit, always in the training data
    (weight ``fit_weight``), never scored.  For each held-out block the
    setting is chosen by an inner cross-validation on the remaining blocks
    (so a penalty weight is chosen as fairly as a time constant), then
    fitted on all remaining blocks and used to predict the held-out one.  The inner cross-validation leaves out :data:`INNER_FOLDS`
    contiguous groups of the remaining blocks in turn.  The inner choice
    honours the sign constraints through :func:`feasible_coefficients`
    (nearly optimal); the outer fits solve them exactly.  With the settings already chosen for each
    held-out block, :func:`predict_at_chosen` gives the prediction alone.
    """
    nb = blocks.count
    m = gap.size
    ind = onehot(blocks)
    gg = ind @ (gap * gap)
    normals = _normals(designs, gap, ind, fit_residual, fit_weight)
    others = np.arange(nb)
    prediction = np.zeros(m)
    picked = np.zeros(nb, int)
    # outer leave-one-block-out errors of every setting (for the full-data choice)
    outer = np.zeros((len(normals), nb))
    outer_coef = []
    for s, ne in enumerate(normals):
        coef = solve_coefficients(ne.gram - ne.block_gram, ne.rhs - ne.block_rhs, ne.nonneg)  # (B, k)
        outer_coef.append(coef)
        outer[s] = _block_sse(ne, gg, coef, others)
    # inner cross-validation errors (S, B): the setting chosen for each held-out block
    inner = None
    if len(normals) > 1:
        scratch, shared = np.empty(BATCH_ENTRIES), {}
        inner = np.stack([_inner_errors(ne, gg, scratch, shared) for ne in normals])
    for b in range(nb):
        best = 0 if inner is None else int(np.argmin(inner[:, b]))
        rows = blocks.index == b
        prediction[rows] = normals[best].check[rows] @ outer_coef[best][b]
        picked[b] = best
    s_full = int(np.argmin(outer.sum(axis=1)))
    ne = normals[s_full]
    full = solve_coefficients(ne.gram, ne.rhs, ne.nonneg)
    return CrossValidation(prediction, picked, s_full, full / ne.scale)


def predict_at_chosen(gap: np.ndarray, blocks: Blocks, designs, chosen: np.ndarray,
                      fit_residual: np.ndarray | None = None, fit_weight: float = 1.0) -> np.ndarray:
    """Leave-one-block-out predictions of ``gap`` ``(m,)`` with the setting ``chosen[b]`` of ``designs``
    for each held-out block ``b`` (chosen without that block elsewhere, e.g. by a candidate's own
    cross-validation): :func:`cross_validate`'s outer fits, solved only for the chosen setting of each
    block -- the same numbers, without the systems of the settings no block uses.  ``designs``: indexed
    by setting (a list, or a mapping holding at least the chosen ones)."""
    ind = onehot(blocks)
    chosen = np.asarray(chosen, dtype=int)
    prediction = np.zeros(gap.size)
    for s in np.unique(chosen):
        ne = _normal(designs[s], gap, ind, fit_residual, fit_weight)
        mine = np.flatnonzero(chosen == s)
        coef = solve_coefficients(ne.gram - ne.block_gram[mine], ne.rhs - ne.block_rhs[mine], ne.nonneg)
        for b, c in zip(mine, coef):
            rows = blocks.index == b
            prediction[rows] = ne.check[rows] @ c
    return prediction


def coefficients_without(design: Design, gap: np.ndarray, blocks: Blocks, exclude: np.ndarray,
                         fit_residual: np.ndarray | None = None, fit_weight: float = 1.0) -> np.ndarray:
    """``design``'s coefficients ``(k,)`` (in its columns' units) fitted on the identification term and every
    block but those in ``exclude`` (block numbers): a linearisation point for those blocks that never saw
    them."""
    ne = _normal(design, gap, onehot(blocks), fit_residual, fit_weight)
    out = np.asarray(exclude, dtype=int)
    coef = solve_coefficients(ne.gram - ne.block_gram[out].sum(axis=0), ne.rhs - ne.block_rhs[out].sum(axis=0),
                              ne.nonneg)
    return coef / ne.scale


def onehot(blocks: Blocks) -> np.ndarray:
    """``(B, m)`` indicator of each block's points."""
    m = blocks.index.size
    out = np.zeros((blocks.count, m))
    out[blocks.index, np.arange(m)] = 1.0
    return out


def bootstrap_mse(sse_blocks: np.ndarray, blocks: Blocks, n_boot: int = N_BOOT, seed: int = 0) -> np.ndarray:
    """Stratified block bootstrap of mean squared errors.

    ``sse_blocks`` ``(c, B)``: sum of squared errors per block for ``c``
    models (the baseline and each candidate).  Each check run's blocks are
    resampled with replacement; returns ``(n_boot, c)`` mean squared errors,
    the same resamples for every model.
    """
    rng = np.random.default_rng(seed)
    nb = blocks.count
    flat = []
    for r in np.unique(blocks.run):
        mine = np.flatnonzero(blocks.run == r)
        draws = mine[rng.integers(0, mine.size, size=(n_boot, mine.size))]
        flat.append((np.arange(n_boot)[:, None] * nb + draws).ravel())
    counts = np.bincount(np.concatenate(flat), minlength=n_boot * nb).reshape(n_boot, nb).astype(float)
    points = counts @ blocks.size
    return (counts @ np.asarray(sse_blocks, dtype=float).T) / points[:, None]
