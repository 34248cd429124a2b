"""Position-sensitive detector and optical-lever response functions ``F_c(z)`` with ``F(0) = 0, F'(0) = 1``.

``z`` is the spot's position from the detector's null, in units of half the output swing; ``c >= 0`` the
nonlinearity parameter (``c = 0``: linear).  Every ``F_c`` is smooth and strictly increasing in ``z``.

* ``quadrant``: a split (bi-cell / quadrant) photodiode with a Gaussian spot: the difference signal is
  ``erf(a z)`` (``a^2 = c``; ``a`` grows with the swing relative to the spot size): compressive, odd.
* ``lateral_edge``: a lateral-effect PSD, linear near its centre, compressed (tetra-lateral ``pincushion``)
  or expanded (duo-lateral ``barrel``) towards its edges: ``z / sqrt(1 + c z^2)`` or ``z sqrt(1 + c z^2)``.
* ``lever_tan``: the optical lever's geometry on a flat detector, ``tan(b z) / b`` (``b^2 = c``, capped
  below the pole): expansive, odd.
* ``sheet_gradient``: a resistive layer whose sheet resistance varies across the detector: exponential
  position response ``expm1(c z) / c`` (sign drawn): even-order, asymmetric.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf


def response(kind: str, sign: int, c: float, z: np.ndarray, zcap: float = 3.0) -> np.ndarray:
    z = np.asarray(z, dtype=float)
    if c <= 0.0:
        return z.copy()
    if kind == "quadrant":
        a = np.sqrt(c)
        return erf(a * z) * np.sqrt(np.pi) / (2.0 * a)
    if kind == "lateral_edge":
        return z / np.sqrt(1.0 + c * z * z) if sign > 0 else z * np.sqrt(1.0 + c * z * z)
    if kind == "lever_tan":
        bcap = 0.9 * (np.pi / 2.0) / zcap
        b = bcap * np.tanh(np.sqrt(c) / bcap)
        return np.tan(b * z) / b
    if kind == "sheet_gradient":
        cc = sign * c
        return np.expm1(cc * z) / cc
    raise ValueError(kind)
