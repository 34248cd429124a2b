"""Real roots of a low-order polynomial on an interval, and where it comes closest to zero there.

Between two walls of the grid and two corners of the memory curve the
Preisach output is a quadratic of the input (:mod:`identify.everett`); a
fitted effect that is a polynomial of the heater voltage raises the degree
to at most four (``joule_power``).  So every candidate voltage of the
inversion is a root of a polynomial of degree <= 4 on a known interval:
closed form up to degree 2, the eigenvalues of the companion matrix
(:func:`numpy.roots`) polished by Newton steps above.

Polynomials are given by their coefficients in ascending order,
``c[0] + c[1] f + c[2] f^2 + ...``, in a local variable ``f`` (a cell's
fraction, so ``|f| <= 1`` and the coefficients are of one scale).
"""

from __future__ import annotations

import math

import numpy as np

#: Relative size below which a coefficient counts as zero against the polynomial's scale.
NEGLIGIBLE = 1e-14
#: Slack (in ``f``) by which a root may lie outside its interval and still count (rounding).
SLACK = 1e-12


def evaluate(c: tuple[float, ...] | list[float], f: float) -> float:
    """``c[0] + c[1] f + ...`` (Horner)."""
    out = 0.0
    for x in reversed(c):
        out = out * f + x
    return out


def _scale(c, lo: float, hi: float) -> float:
    r = max(abs(lo), abs(hi), 1.0)
    return max(abs(x) * r ** k for k, x in enumerate(c))


def roots_between(c: tuple[float, ...] | list[float], lo: float, hi: float) -> list[float]:
    """The real roots of ``c`` in ``[lo, hi]`` (``lo <= hi``), ascending.

    A polynomial that vanishes identically on the interval (every
    coefficient negligible) gives ``[lo, hi]``: every point is a root, the
    caller takes the end it wants.
    """
    scale = _scale(c, lo, hi)
    if scale == 0.0:
        return [lo, hi]
    tol = NEGLIGIBLE * scale
    deg = len(c) - 1
    while deg > 0 and abs(c[deg]) * max(abs(lo), abs(hi), 1.0) ** deg <= tol:
        deg -= 1
    if deg == 0:
        return [lo, hi] if abs(c[0]) <= tol else []
    slack = SLACK * max(hi - lo, 1.0)
    if deg == 1:
        found = [-c[0] / c[1]]
    elif deg == 2:
        a, b, k = c[2], c[1], c[0]
        disc = b * b - 4.0 * a * k
        if disc < 0.0:
            # a double root lost to rounding still counts when the vertex touches zero
            v = -b / (2.0 * a)
            found = [v] if abs(evaluate((k, b, a), v)) <= 4 * tol else []
        else:
            q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            found = [q / a] + ([k / q] if q != 0.0 else [])
    else:
        found = _polished(c[: deg + 1], tol)
    out = sorted(min(max(r, lo), hi) for r in found if lo - slack <= r <= hi + slack)
    return out


def _polished(c, tol: float) -> list[float]:
    """Real roots of a cubic or quartic: companion eigenvalues, nearly real ones polished by Newton."""
    raw = np.roots(np.asarray(c[::-1], dtype=float))
    d = [k * x for k, x in enumerate(c)][1:]
    out = []
    for z in raw:
        if abs(z.imag) > 1e-6 * max(1.0, abs(z.real)):
            continue
        x = float(z.real)
        for _ in range(3):
            g = evaluate(c, x)
            dg = evaluate(d, x)
            if dg == 0.0:
                break
            x -= g / dg
        if abs(evaluate(c, x)) <= 1e3 * tol:
            out.append(x)
    return out


def closest_to_zero(c: tuple[float, ...] | list[float], lo: float, hi: float) -> tuple[float, float]:
    """``(f, value)``: where on ``[lo, hi]`` the polynomial ``c`` is smallest in magnitude, and its value.

    The candidates are the ends and the stationary points (the roots of the
    derivative); a polynomial without a root on the interval keeps one sign
    there, so its smallest magnitude is at one of them.
    """
    best_f, best = lo, evaluate(c, lo)
    at_hi = evaluate(c, hi)
    if abs(at_hi) < abs(best):
        best_f, best = hi, at_hi
    d = [k * x for k, x in enumerate(c)][1:]
    if len(d) > 1:
        for f in roots_between(d, lo, hi):
            g = evaluate(c, f)
            if abs(g) < abs(best):
                best_f, best = f, g
    return best_f, best
