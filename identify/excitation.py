"""Identification and validation input sequences.

The *damped oscillation* (paper figure 2) steps one wall at a time::

    v_L, v_{L-1}, ..., v_0, v_1, ..., v_{L-1}, v_{L-2}, ..., v_1, v_2, ...

each sweep one wall shorter than the last, until a sweep would be empty.  It
has ``1 + L + (L-1) + ... + 1 = L(L+1)/2 + 1 = N`` points, every one on a
wall, and its regressor matrix ``S`` (cells + bias) is square and invertible
(Proposition 1; checked for L = 1..60 in the tests).

The thermal-term point (section 5.2).  On the walls, ``v`` is an exact
affine function of the diagonal cells' signed areas (diagonal cell ``(i, i)``
is +1 exactly when the input is above it, whatever the history), so
``v = v_min + h (L + sum_i s_ii) / 2`` and *no* extra on-wall input can make
the ``(N+1) x (N+1)`` matrix with the ``c_d`` column invertible.  The paper
says "any value other than 0"; with exact signed areas that is not so.  We
add one input *half a cell above the last point*: there the diagonal cell's
signed area is quadratic in the input, the identity breaks and the matrix is
invertible (checked for L = 1..60).  The thermal term is then identified
through this one point, which makes ``c_d`` sensitive to noise on it.  Other
off-wall points (and points beyond the range, where the memory saturates and
only ``c_d v`` changes) work too, as do other orderings of the oscillation:
identification accepts any square design whose ``S`` is invertible, checked
numerically (:mod:`identify.regressor_design`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import IdentifyError
from .grid import Grid


def damped_oscillation_walls(levels: int) -> np.ndarray:
    """Wall indices of the damped oscillation for ``levels`` = L, shape ``(N,)``."""
    if levels < 1:
        raise IdentifyError(f"levels must be >= 1, got {levels}")
    seq = [levels]
    cur, low, high = levels, 0, levels - 1
    falling = True
    while True:
        if falling:
            if cur - 1 < low:
                break
            seq.extend(range(cur - 1, low - 1, -1))
            cur, low = low, low + 1
        else:
            if cur + 1 > high:
                break
            seq.extend(range(cur + 1, high + 1))
            cur, high = high, high - 1
        falling = not falling
    return np.asarray(seq, dtype=np.int64)


def thermal_point(grid: Grid) -> float:
    """The extra input (V) that makes the thermal-term design invertible.

    Half a cell above the damped oscillation's last point (see module doc).
    """
    last = damped_oscillation_walls(grid.levels)[-1]
    return float(grid.v_min + (last + 0.5) * grid.step)


def damped_oscillation(grid: Grid, thermal_term: bool = False) -> np.ndarray:
    """The damped-oscillation input (V): ``N`` points, or ``N + 1`` with the thermal point."""
    v = grid.at_walls(damped_oscillation_walls(grid.levels))
    if thermal_term:
        v = np.append(v, thermal_point(grid))
    return v


def random_input(grid: Grid, n: int, seed: int | None = None) -> np.ndarray:
    """A random validation input (paper figure 6): ``n`` values uniform on the range (V)."""
    if n < 1:
        raise IdentifyError(f"a random input needs at least 1 point, got {n}")
    rng = np.random.default_rng(seed)
    return grid.v_min + (grid.v_max - grid.v_min) * rng.random(n)


@dataclass(frozen=True)
class Excitation:
    """An input sequence with what produced it (stored with sessions)."""

    kind: str
    grid: Grid
    inputs: np.ndarray
    thermal_term: bool = False
    seed: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def damped(cls, grid: Grid, thermal_term: bool = True) -> "Excitation":
        return cls("damped", grid, damped_oscillation(grid, thermal_term), thermal_term)

    @classmethod
    def random(cls, grid: Grid, n: int, seed: int | None = None) -> "Excitation":
        return cls("random", grid, random_input(grid, n, seed), seed=seed)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            **self.grid.to_dict(),
            "thermal_term": self.thermal_term,
            "seed": self.seed,
            "n_points": int(len(self.inputs)),
            **self.extra,
        }
