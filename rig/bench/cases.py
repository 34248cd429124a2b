"""The benchmark problems: the simulated VO2 device identified from a noisy damped oscillation.

One case is ``(levels, measurements)``; its problem is rebuilt identically
from the seed wherever it is needed (the parent process and each measuring
subprocess), so the dense reference and the fast path see the same data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from identify import PreisachModel, Problem, damped_oscillation
from identify.fit import measurement_rows
from identify.grid import n_cells
from drivers.sim import SimParams, SimVO2

#: Peak-to-peak of the uniform PSD noise added to the simulated outputs (um), as in ``rig demo``.
NOISE_UM = 0.05

#: The cases of issue 8: ``(L, M)``; M is about 65 % of the N + 1 points.
DEFAULT_CASES = ((30, 300), (100, 3284), (200, 13_000))


@dataclass(frozen=True)
class Case:
    """``levels`` = L, ``measurements`` = M of the ``N + 1`` damped-oscillation points."""

    levels: int
    measurements: int
    seed: int = 0

    @property
    def points(self) -> int:
        return n_cells(self.levels) + 2

    def truth(self) -> PreisachModel:
        return simulated_actuator(self.levels)

    def data(self) -> tuple[PreisachModel, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``truth, inputs (V), noise-free outputs, measured outputs (um), measured rows``."""
        truth = self.truth()
        v = damped_oscillation(truth.grid, thermal_term=True)
        clean = truth.predict(v)
        rng = np.random.default_rng(self.seed)
        noisy = clean + rng.uniform(-NOISE_UM / 2, NOISE_UM / 2, v.size)
        rows = measurement_rows(truth.grid, v, self.measurements, self.seed, True)
        return truth, v, clean, noisy, rows

    def problem(self) -> Problem:
        """The identification problem (nothing large built yet)."""
        truth, v, _, noisy, rows = self.data()
        return Problem.build(truth.grid, v, noisy, rows, thermal_term=True)


def simulated_actuator(levels: int) -> PreisachModel:
    """The default simulated VO2 device's model on ``levels`` levels (as ``rig demo`` uses)."""
    return SimVO2(SimParams(levels=levels)).true_model()


def parse_case(text: str) -> Case:
    """``"L:M"`` -> :class:`Case`."""
    try:
        levels, measurements = (int(part) for part in text.split(":"))
    except ValueError:
        raise ValueError(f"a case is L:M (levels and measurements), got {text!r}") from None
    case = Case(levels, measurements)
    if levels < 1 or not 1 <= measurements <= case.points:
        raise ValueError(f"case {text}: need L >= 1 and 1 <= M <= N+1 = {case.points}")
    return case
