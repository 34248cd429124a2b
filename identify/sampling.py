"""Which rows are measured: ``M`` of the ``N`` applied inputs, chosen at random with a seed.

The compressive-sensing experiment measures only some of the outputs of an
applied input sequence (the paper's ``M < N``); the identification methods'
:class:`~identify.methods.Problem`, the acquisition plan and the study all
choose them here, so the same seed chooses the same rows everywhere.
"""

from __future__ import annotations

import numpy as np

from .errors import IdentifyError


def choose_rows(n: int, m: int, seed: int | None, include: tuple[int, ...] = ()) -> np.ndarray:
    """``m`` of the ``n`` row indices, sorted: ``include`` plus the rest uniformly at random."""
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or not 1 <= m <= n:
        raise IdentifyError(f"number of measurements M={m} must be between 1 and N={n}")
    fixed = np.unique(np.asarray(include, dtype=np.int64))
    if fixed.size > m:
        raise IdentifyError(f"M={m} is fewer than the {fixed.size} rows that must be measured")
    rng = np.random.default_rng(seed)
    rest = np.setdiff1d(np.arange(n), fixed)
    return np.sort(np.concatenate([fixed, rng.choice(rest, size=m - fixed.size, replace=False)]))
