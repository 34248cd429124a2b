"""The VO2 film: the base device's Preisach hysteresis, with optional accommodation and mean-field interaction.

* **Accommodation** (outside): the cell weights change with the number of transformation cycles the film
  has gone through, ``d_c -> d_c (1 + e(N) m_c)``.  By linearity the phase part is
  ``P = P_base + e(N) P_aux`` where ``P_aux`` is the Preisach output of an auxiliary device whose density is
  ``d * m``: both are base ``Hysteresis`` objects moved together.  The mask ``m`` lives on the Preisach
  plane; the cells' switching walls are probed once per grid from the base memory curve.
* **Interaction** (library): the hysterons feel ``input + kappa * h((P - P_ref) / swing)`` (a mean field of
  the transformation stress, in temperature -- Clausius-Clapeyron -- or in heater-volt units), solved
  self-consistently with Brent's method at every move; the loop gain is kept below ``GAIN_MAX``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import brentq

GAIN_MAX = 0.8


def probe_cell_walls(device) -> tuple[np.ndarray, np.ndarray]:
    """Indices (0..levels) of each cell's switching-up wall ``a`` and switching-down wall ``b`` (a > b).

    Found by sweeping a base ``Hysteresis`` up from negative saturation (and down from positive saturation)
    over the grid's walls and watching which cells' signed areas flip.
    """
    key = (device.levels, float(device.v_min_V), float(device.v_max_V))
    if key in _WALLS:
        return _WALLS[key]
    L = device.levels
    walls = device.v_min_V + (device.v_max_V - device.v_min_V) * np.arange(L + 1) / L
    h = device.hysteresis()
    sa = lambda: np.asarray(h._curve.signed_areas(h._grid), dtype=float)  # noqa: E731  (base internals)
    n = device.density_um.size
    up = np.full(n, -1)
    prev = sa()
    for k in range(1, L + 1):
        h.move(walls[k])
        s = sa()
        up[(s > 0) & (prev <= 0) & (up < 0)] = k
        prev = s
    down = np.full(n, -1)
    for k in range(L - 1, -1, -1):
        h.move(walls[k])
        s = sa()
        down[(s < 0) & (prev >= 0) & (down < 0)] = k
        prev = s
    up[up < 0] = L
    down[down < 0] = 0
    _WALLS[key] = (up, down)
    return up, down


_WALLS: dict = {}


def accommodation_mask(device, form: dict) -> np.ndarray:
    """The mask ``m`` (max |m| = 1 over cells that carry weight), times the form's sign."""
    up, down = probe_cell_walls(device)
    L = device.levels
    dv = (device.v_max_V - device.v_min_V) / L
    a_V = device.v_min_V + (up - 0.5) * dv
    b_V = device.v_min_V + (down + 0.5) * dv
    b_V = np.minimum(b_V, a_V)
    Ta = device.ambient_C + device.kelvin_per_V2 * a_V**2
    Tb = device.ambient_C + device.kelvin_per_V2 * b_V**2
    width, centre = Ta - Tb, 0.5 * (Ta + Tb)
    d = np.asarray(device.density_um, float)
    wts = d / d.sum()
    kind = form["mask"]
    if kind == "uniform":
        m = np.ones_like(d)
    elif kind == "width":
        m = width - wts @ width
    elif kind == "centre":
        m = centre - wts @ centre
    elif kind == "window":
        order = np.argsort(centre)
        cum = np.cumsum(wts[order])
        lo = centre[order][np.searchsorted(cum, 0.05)]
        hi = centre[order][min(np.searchsorted(cum, 0.95), cum.size - 1)]
        cw = lo + form["window_centre"] * (hi - lo)
        sw = max(form["window_width"] * (hi - lo), 0.5)
        m = np.exp(-0.5 * ((centre - cw) / sw) ** 2)
        m = m - wts @ m
    elif kind == "grains":
        rng = np.random.default_rng(int(form["mask_seed"]))
        field = rng.standard_normal((L + 1, L + 1))
        ell = float(form.get("grain_correlation", 0.0))
        if ell > 0.2:
            from scipy.ndimage import gaussian_filter
            field = gaussian_filter(field, ell, mode="nearest")
        m = field[up, down]
        m = m - wts @ m
    else:
        raise ValueError(kind)
    carry = d > 0.01 * d.max()
    scale = np.max(np.abs(m[carry])) if np.any(carry) else 1.0
    if scale <= 0:
        scale = 1.0
    return form.get("mask_sign", 1) * m / scale


class Film:
    """Phase part of the deflection (um) with memory, optional accommodation and interaction."""

    def __init__(self, device, aux_density: np.ndarray | None = None, interaction: dict | None = None) -> None:
        self.device = device
        self.h = device.hysteresis()
        self.aux = None
        if aux_density is not None:
            self.aux = dataclasses.replace(device, density_um=np.asarray(aux_density, float)).hysteresis()
        self.e = 0.0                           # accommodation factor e(N)
        self.inter = interaction               # dict: units, kappa, sign, quad, p_ref, swing, k
        self.P_base = -device.phase_swing_um   # last base phase (for cycle counting)
        self._pa = self.aux.value() if self.aux is not None else 0.0
        self.dP_base = 0.0

    # ---------------------------------------------------------------- raw phase
    def _peek(self, x: float) -> tuple[float, float]:
        pb = self.h.peek(x)
        pa = self.aux.peek(x) if self.aux is not None else 0.0
        return pb, pa

    def _move(self, x: float) -> tuple[float, float]:
        pb = self.h.move(x)
        pa = self.aux.move(x) if self.aux is not None else 0.0
        return pb, pa

    def _total(self, pb: float, pa: float) -> float:
        return pb + self.e * pa if self.aux is not None else pb

    # ---------------------------------------------------------------- interaction
    def _field(self, P: float) -> float:
        it = self.inter
        p = (P - it["p_ref"]) / it["swing"]
        return it["sign"] * it["kappa"] * it["swing"] * (p + it["quad"] * p * p)

    def _effective(self, x: float) -> float:
        """The input the hysterons feel, solved self-consistently (V)."""
        it = self.inter
        k = it["k"]
        span = abs(it["kappa"]) * it["swing"] * it["hmax"] + 1e-9
        if it["units"] == "temperature":
            th = k * x * x
            to_x = lambda t: float(np.sqrt(max(t, 0.0) / k))  # noqa: E731
            r = lambda t: t - th - self._field(self._total(*self._peek(to_x(t))))  # noqa: E731
            return to_x(self._root(r, th, span))
        r = lambda xe: xe - x - self._field(self._total(*self._peek(xe)))  # noqa: E731
        return self._root(r, x, span)

    @staticmethod
    def _root(r, centre: float, span: float) -> float:
        """The root of the increasing residual ``r`` near ``centre``: a fixed-point step and secant iterations
        (the loop gain is small), falling back on Brent's method in a (widened if needed) bracket."""
        tol = 1e-11 * (1.0 + abs(centre))
        a = centre
        ra = r(a)
        if abs(ra) <= tol:
            return a
        b = a - ra                               # the fixed-point step: input + field(P(input))
        rb = r(b)
        for _ in range(12):
            if abs(rb) <= tol:
                return b
            if rb == ra:
                break
            c = b - rb * (b - a) / (rb - ra)
            a, ra = b, rb
            b, rb = c, r(c)
        lo, hi = centre - span, centre + span
        for _ in range(60):
            if r(lo) <= 0.0:
                break
            lo -= span
        for _ in range(60):
            if r(hi) >= 0.0:
                break
            hi += span
        return float(brentq(r, lo, hi, xtol=1e-12, rtol=1e-12))

    # ---------------------------------------------------------------- public
    def move(self, x: float) -> float:
        if self.inter is not None:
            x = self._effective(x)
        pb, pa = self._move(x)
        self._pa = pa
        self.dP_base = abs(pb - self.P_base)
        self.P_base = pb
        return self._total(pb, pa)

    def value(self) -> float:
        if self.aux is None:
            return self.P_base
        return self.P_base + self.e * self._pa
