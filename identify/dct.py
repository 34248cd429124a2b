"""The orthonormal DCT ``Psi`` of equations (8)-(9) and (13)-(16).

``q = Psi b`` is the orthonormal DCT-II of a length-N vector, so
``Psi^{-1} = Psi^T`` is the orthonormal DCT-III.  Both act along axis 0.  ``scipy.fft`` is imported on first use (about
50 ms that a command which never needs a DCT should not pay at start-up).
"""

from __future__ import annotations

import numpy as np


def dct(b: np.ndarray) -> np.ndarray:
    """``Psi @ b`` along axis 0."""
    import scipy.fft

    return scipy.fft.dct(np.asarray(b, dtype=float), type=2, norm="ortho", axis=0)


def idct(q: np.ndarray) -> np.ndarray:
    """``Psi^T @ q = Psi^{-1} @ q`` along axis 0."""
    import scipy.fft

    return scipy.fft.idct(np.asarray(q, dtype=float), type=2, norm="ortho", axis=0)


def dct_matrix(n: int) -> np.ndarray:
    """The dense ``n x n`` orthonormal DCT matrix ``Psi``."""
    return dct(np.eye(n))
