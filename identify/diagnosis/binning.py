"""Where the model misses: check residuals binned by what the input history was doing.

Residuals are ``model - measured`` (um), as :mod:`identify.validation`.
They are binned by six quantities (:data:`BY`): the input level, the
branch (heating, cooling, first step after a reversal), the time since the
last reversal, the signed size of the last step, the predicted output and
the session time; runs made of curves (FORC) also by the reversal input of
every point (the curve's reversal field).  Numeric quantities get quantile bins (equal counts), so
every bin has enough points to say something.

A bin *stands out beyond noise* when its mean or its rms is larger than
the noise floor allows: ``|mean| / (floor / sqrt(n))`` beyond the normal
quantile, or ``sum (r / floor_n)^2`` beyond the chi-square quantile with
``n`` degrees of freedom -- both at a family-wise 5 % over all bins
(Bonferroni).  Without a noise floor the mean is compared with the bin's
own scatter (a t-test), and only the mean can stand out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..runs import AFTER_REVERSAL, BRANCH_NAMES, COOLING, HEATING
from .quantiles import chi2_isf, normal_isf, t_isf

#: The binned quantities and their units, in report order.
BY = {
    "input_V": "V",
    "branch": "",
    "time_since_reversal_s": "s",
    "last_step_V": "V",
    "predicted_um": "um",
    "session_time_s": "s",
    "reversal_V": "V",
}
#: Quantile bins per numeric quantity.
N_BINS = 8
#: Family-wise false-alarm rate over all bins.
ALPHA = 0.05
#: Fewest points for a bin to be tested.
MIN_TESTED = 3


@dataclass(frozen=True)
class Bin:
    """One bin: edges ``lo``..``hi`` (the branch code for ``branch``), ``label`` for categorical
    bins, the residual's ``mean_um`` and ``rms_um``, ``n`` points, ``significant``."""

    lo: float
    hi: float
    label: str
    mean_um: float
    rms_um: float
    n: int
    significant: bool


@dataclass(frozen=True)
class Binning:
    """The bins of one quantity (``by``, in ``unit``)."""

    by: str
    unit: str
    bins: tuple[Bin, ...]


def _edges(x: np.ndarray, n_bins: int) -> np.ndarray:
    edges = np.unique(np.quantile(x, np.linspace(0.0, 1.0, n_bins + 1)))
    if edges.size < 2:
        edges = np.array([x.min(), x.max()])
    return edges


def _assign(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)


def _groups(by: str, x: np.ndarray) -> list[tuple[float, float, str, np.ndarray]]:
    if by == "branch":
        return [(float(c), float(c), BRANCH_NAMES[c], x == c) for c in (HEATING, COOLING, AFTER_REVERSAL)]
    finite = np.isfinite(x)
    if not finite.any():
        return []
    edges = _edges(x[finite], N_BINS)
    which = np.where(finite, _assign(np.where(finite, x, edges[0]), edges), -1)
    return [(float(edges[b]), float(edges[b + 1]), "", which == b) for b in range(edges.size - 1)]


def bin_residuals(
    features: dict[str, np.ndarray], residual: np.ndarray, floor: np.ndarray | None,
    units: dict[str, str] | None = None,
) -> list[Binning]:
    """Bin ``residual`` ``(m,)`` by each quantity of :data:`BY` in ``features`` (each ``(m,)``).

    ``floor`` ``(m,)``: the noise floor at every point (um), or None.
    ``units`` renames the units of :data:`BY` for the runs at hand
    (``{"V": "T", "um": "A m^2"}`` for a FORC measurement).
    """
    units = units or {}
    r = np.asarray(residual, dtype=float)
    grouped = [(by, _groups(by, np.asarray(features[by], dtype=float))) for by in BY if by in features]
    tests = sum(1 for _, groups in grouped for g in groups if g[3].sum() >= MIN_TESTED)
    z_crit = normal_isf(ALPHA / (2 * max(tests, 1)))
    out = []
    for by, groups in grouped:
        bins = []
        for lo, hi, label, mask in groups:
            n = int(mask.sum())
            if n == 0:
                continue
            rb = r[mask]
            mean, rms = float(rb.mean()), float(np.sqrt(np.mean(rb**2)))
            significant = False
            if n >= MIN_TESTED:
                if floor is not None:
                    f = floor[mask]
                    z = abs(mean) / (np.sqrt(np.mean(f**2)) / np.sqrt(n))
                    chi = float(np.sum((rb / f) ** 2))
                    significant = bool(z > z_crit or chi > chi2_isf(ALPHA / max(tests, 1), n))
                else:
                    sd = float(rb.std(ddof=1))
                    t = abs(mean) / (sd / np.sqrt(n)) if sd > 0 else 0.0
                    significant = bool(t > t_isf(ALPHA / (2 * max(tests, 1)), n - 1))
            bins.append(Bin(lo, hi, label, mean, rms, n, significant))
        out.append(Binning(by, units.get(BY[by], BY[by]), tuple(bins)))
    return out
