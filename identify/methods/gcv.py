"""Choosing the roughness weight by generalised cross-validation (GCV).

For ``min ||y - X w||^2 + lam ||D mu||^2`` over ``w = (mu, free)`` (no sign
constraint here) the fitted outputs are ``H(lam) y`` and

    GCV(lam) = M ||(I - H(lam)) y||^2 / (M - trace H(lam))^2,

an estimate of the prediction error on unseen rows that needs neither the
noise level nor the true density (Golub, Heath and Wahba 1979).  Writing
``mu = c 1 + W b`` (:func:`~identify.methods.triangle_penalty.standard_form`)
leaves the constant weight ``c`` and the free parameters unpenalised and
makes the rest ridge regression in ``b``; one symmetric eigendecomposition
then gives GCV on a whole grid of weights at once:

* data space, ``(M, M)``, when the measured rows ``X`` are at hand and
  ``M`` is below the number of cells;
* parameter space, ``(P, P)``, from the normal equations otherwise.

The weight is chosen on the unconstrained problem and then used with the
non-negativity constraint (the constraint only removes solutions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.linalg.blas

from ..grid import Grid
from .normal_equations import NormalEquations
from .triangle_penalty import grounded_root, standard_form

#: Candidate weights span this many decades below/above the data's scale.
DECADES_BELOW, DECADES_ABOVE = 10, 4
#: Number of candidate weights on the logarithmic grid.
GRID_POINTS = 241


@dataclass(frozen=True)
class WeightChoice:
    """The chosen weight and its GCV score; ``edf`` is ``trace H`` (effective parameters)."""

    weight: float
    score: float
    edf: float
    space: str


def _orthonormal_range(a: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space of ``a`` (rank-revealing)."""
    u, s, _ = np.linalg.svd(a, full_matrices=False)
    tol = s.max(initial=0.0) * max(a.shape) * np.finfo(float).eps
    return u[:, s > tol]


def _pinv_sym(a: np.ndarray) -> tuple[np.ndarray, int]:
    values, vectors = np.linalg.eigh(a)
    tol = np.abs(values).max(initial=0.0) * a.shape[0] * np.finfo(float).eps
    keep = values > tol
    return (vectors[:, keep] / values[keep]) @ vectors[:, keep].T, int(keep.sum())


def _unpenalised_basis(n_cells: int, n_free: int) -> np.ndarray:
    z = np.zeros((n_cells + n_free, 1 + n_free))
    z[:n_cells, 0] = 1.0 / np.sqrt(n_cells)
    z[n_cells:, 1:] = np.eye(n_free)
    return z


def _spectrum_data_space(x: np.ndarray, y: np.ndarray, grid: Grid, n_free: int):
    n_cells = grid.n_cells
    q = _orthonormal_range(x @ _unpenalised_basis(n_cells, n_free))
    # X W W^T X^T with the constants projected out: X F F^T X^T does (grounded_root), F triangular
    b = scipy.linalg.blas.dtrmm(1.0, grounded_root(grid), x[:, :n_cells], side=1, lower=1)
    b -= q @ (q.T @ b)
    yp = y - q @ (q.T @ y)
    sigma2, rss = _ridge_along(b @ b.T, yp)
    # RSS(lam) = sum (lam / (s + lam))^2 c^2, from the tridiagonal form
    return np.clip(sigma2, 0.0, None), rss, 0.0, q.shape[1], "data"


def _ridge_along(k: np.ndarray, v: np.ndarray):
    """Eigenvalues of the symmetric PSD ``k`` and ``lams -> ||lam (k + lam I)^{-1} v||^2``.

    Without eigenvectors (the ``M x M`` eigendecomposition's most expensive
    part): a reflector ``H`` maps ``v`` to ``||v|| e_1``, LAPACK's
    tridiagonal reduction of ``H k H`` (``dsytrd``, lower: its reflectors
    leave ``e_1`` alone) gives ``T = Q^T H k H Q`` with ``Q^T H v = ||v||
    e_1``, so ``||lam (k + lam I)^{-1} v|| = lam ||v|| ||(T + lam I)^{-1}
    e_1||``: one ``LDL^T`` sweep of the tridiagonal ``T + lam I`` (positive
    definite) per weight, all weights at once.  The eigenvalues are those of
    ``T`` (``dstev``).
    """
    m = v.size
    norm = float(np.linalg.norm(v))
    k = np.array(k, dtype=float, order="F")  # a copy: updated in place below
    if norm > 0.0:
        u = v.copy()
        u[0] += np.copysign(norm, v[0])
        u /= np.linalg.norm(u)
        ku = k @ u
        # H k H = k + u z^T + z u^T, z = 2 (u^T k u) u - 2 k u: a rank-two update of the lower triangle
        z = 2.0 * float(u @ ku) * u - 2.0 * ku
        k = scipy.linalg.blas.dsyr2(1.0, u, z, a=k, lower=1, overwrite_a=1)
    if m == 1:
        d, e = np.array([k[0, 0]]), np.zeros(0)
    else:
        _, d, e, _, info = scipy.linalg.lapack.dsytrd(k, lower=1, overwrite_a=1)
        if info != 0:  # pragma: no cover - LAPACK argument error
            raise np.linalg.LinAlgError(f"dsytrd failed ({info})")
    values = scipy.linalg.lapack.dstev(d, e, compute_v=0)[0] if m > 1 else d.copy()
    e2 = e * e

    def rss(lams: np.ndarray) -> np.ndarray:
        if norm == 0.0:
            return np.zeros(lams.size)
        # e_1^T (T + lam)^{-1} e_1 = 1 / g_0, the continued fraction g_i = d_i + lam - e_i^2 / g_{i+1}
        # (the pivots of T + lam = U D U^T, positive); its derivative gives e_1^T (T + lam)^{-2} e_1
        # = g_0' / g_0^2 with g_i' = 1 + e_i^2 g_{i+1}' / g_{i+1}^2, for every weight at once
        g = d[-1] + lams
        slope = np.ones_like(g)
        for i in range(m - 2, -1, -1):
            t = e2[i] / g
            slope = 1.0 + t * slope / g
            g = (d[i] + lams) - t
        return (lams * norm) ** 2 * slope / g**2

    return values, rss


def _spectrum_parameter_space(ne: NormalEquations, w: np.ndarray, n_free: int):
    n_cells = w.shape[0]
    h, g = ne.hessian, ne.gradient
    z = _unpenalised_basis(n_cells, n_free)
    hz = h @ z
    hzz_inv, rank_z = _pinv_sym(z.T @ hz)
    hzt = hz[:n_cells].T @ w                      # Z^T H T, (kz, n-1)
    htt = w.T @ (h[:n_cells, :n_cells] @ w)       # T^T H T
    gz, gt = z.T @ g, w.T @ g[:n_cells]
    k = htt - hzt.T @ hzz_inv @ hzt
    c = gt - hzt.T @ (hzz_inv @ gz)
    r0 = max(ne.yy - gz @ hzz_inv @ gz, 0.0)
    theta, v = np.linalg.eigh(0.5 * (k + k.T))
    keep = theta > theta.max(initial=0.0) * theta.size * np.finfo(float).eps
    return theta[keep], (v[:, keep].T @ c) ** 2, r0, rank_z, "parameter"


@dataclass(frozen=True)
class GCVCurve:
    """GCV score and effective parameters ``trace H`` on the candidate weights ``lams``."""

    lams: np.ndarray
    score: np.ndarray
    edf: np.ndarray
    space: str


def gcv_curve(ne: NormalEquations, grid: Grid, n_free: int, lams: np.ndarray | None = None) -> GCVCurve | None:
    """GCV on ``lams`` (default: a logarithmic grid around the data's scale).

    ``ne`` are the normal equations of the (scaled) measured rows over
    ``w = (cells, free)`` with ``n_free`` free parameters (``mu0`` and, with
    the thermal term, ``c_d``).  The score is infinite where fewer than half
    a degree of freedom is left (``M - trace H <= 1/2``).  Returns None when
    the data see only the unpenalised directions, up to rounding (no weight
    matters).
    """
    m = ne.n_measured
    if ne.rows_matrix is not None and m < grid.n_cells - 1:
        spec, c2, r0, rank_z, space = _spectrum_data_space(ne.rows_matrix, ne.y, grid, n_free)
    else:
        spec, c2, r0, rank_z, space = _spectrum_parameter_space(ne, standard_form(grid), n_free)
    if spec.max(initial=0.0) <= 1e-12 * max(float(np.trace(ne.hessian)), np.finfo(float).tiny):
        return None
    return curve_from_spectrum(spec, c2, r0, rank_z, space, m, lams)


def curve_from_spectrum(spec, c2, r0, rank_z, space, m, lams=None) -> GCVCurve:
    """GCV on ``lams`` from the ridge spectrum ``spec`` (the penalised directions' ``s_i``,
    shrink factors ``s_i / (s_i + lam)``), the squared projections ``c2`` of the data on
    them, and ``rank_z`` unpenalised directions; ``m`` measured rows.  ``space`` "data":
    ``RSS = sum (1 - f_i)^2 c2_i``; "parameter": from the normal equations, ``r0`` the
    residual of the unpenalised fit.  ``c2`` may instead be a function
    ``lams -> RSS`` (the data-space residuals without eigenvectors).
    """
    top = spec.max(initial=0.0)
    if lams is None:
        lams = top * np.logspace(-DECADES_BELOW, DECADES_ABOVE, GRID_POINTS)
    lams = np.asarray(lams, dtype=float)
    f = spec[None, :] / (spec[None, :] + lams[:, None])          # shrink factors
    if callable(c2):  # the residual as a function of the weights (see _ridge_along)
        rss = c2(lams)
    elif space == "parameter":
        rss = r0 - (c2[None, :] * (spec[None, :] + 2 * lams[:, None])
                    / (spec[None, :] + lams[:, None]) ** 2).sum(axis=1)
    else:
        rss = ((1.0 - f) ** 2 * c2[None, :]).sum(axis=1)
    rss = np.clip(rss, 0.0, None)
    edf = rank_z + f.sum(axis=1)
    dof = m - edf
    with np.errstate(divide="ignore", invalid="ignore"):
        score = np.where(dof > 0.5, m * rss / dof**2, np.inf)
    return GCVCurve(lams, score, edf, space)


def gcv_weight(ne: NormalEquations, grid: Grid, n_free: int) -> WeightChoice:
    """The roughness weight minimising GCV over :func:`gcv_curve`'s grid.

    The weight does not depend on the output scale.  When GCV is undefined
    (too few measurements: ``M`` at most the number of unpenalised
    directions) the largest candidate is taken: the smoothest fit.
    """
    return choose(gcv_curve(ne, grid, n_free))


def choose(curve: GCVCurve | None) -> WeightChoice:
    """The weight minimising GCV on ``curve`` (see :func:`gcv_weight` for the fallbacks)."""
    if curve is None:  # the data see only the unpenalised directions
        return WeightChoice(1.0, float("nan"), float("nan"), "none")
    if not np.any(np.isfinite(curve.score)):
        return WeightChoice(float(curve.lams[-1]), float("nan"), float(curve.edf[-1]), curve.space)
    best = int(np.argmin(curve.score))
    return WeightChoice(float(curve.lams[best]), float(curve.score[best]), float(curve.edf[best]), curve.space)
