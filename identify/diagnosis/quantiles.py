"""Quantiles of the normal, chi-square, Student t and F distributions that the diagnosis tests with.

The same special functions ``scipy.stats`` evaluates them with (``norm``: ``ndtri``; ``chi2``:
``gammaincinv`` and ``chdtri``; ``t``: ``stdtrit``; ``f``: ``fdtri``), so the numbers are identical,
without importing ``scipy.stats`` -- about a second of a cold ``rig diagnose`` on a loaded machine.
Probabilities lie strictly between 0 and 1; degrees of freedom that are not positive give NaN, as
``scipy.stats`` does.  ``scipy.special`` is imported inside the functions: the command's start-up need
not pay for it.
"""

from __future__ import annotations

import numpy as np


def normal_isf(q: float) -> float:
    """``z`` with ``P(Z > z) = q`` for a standard normal ``Z`` (``scipy.stats.norm.isf``)."""
    from scipy import special

    return -special.ndtri(q)


def chi2_ppf(p: float, dof: float) -> float:
    """``x`` with ``P(X < x) = p`` for a chi-square ``X`` of ``dof`` degrees of freedom (``scipy.stats.chi2.ppf``)."""
    from scipy import special

    return 2 * special.gammaincinv(dof / 2, p) if dof > 0 else np.nan


def chi2_isf(q: float, dof: float) -> float:
    """``x`` with ``P(X > x) = q`` for a chi-square ``X`` of ``dof`` degrees of freedom (``scipy.stats.chi2.isf``)."""
    from scipy import special

    return special.chdtri(dof, q) if dof > 0 else np.nan


def t_isf(q: float, dof: float) -> float:
    """``x`` with ``P(T > x) = q`` for a Student ``T`` of ``dof`` degrees of freedom (``scipy.stats.t.isf``)."""
    from scipy import special

    return -special.stdtrit(dof, q) if dof > 0 else np.nan


def f_ppf(q, dfn: float, dfd: float) -> np.ndarray:
    """The ``q`` quantiles ``(len(q),)`` of an F distribution of ``(dfn, dfd)`` degrees of freedom
    (``scipy.stats.f.ppf``)."""
    from scipy import special

    if not (dfn > 0 and dfd > 0):
        return np.full(np.shape(q), np.nan)
    return special.fdtri(dfn, dfd, np.asarray(q, dtype=float))
