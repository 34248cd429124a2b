"""What the study simulates: the paper's section 4 set-up and its sweeps.

A Preisach model with ``L`` levels and no bias (``mu0 = 0``), no thermal
term, driven by the damped oscillation (``N = L (L + 1) / 2 + 1`` inputs);
measurement noise uniform on ``[-D/2, D/2]`` (um); ``M`` of the ``N`` rows
measured, chosen at random.  The input range is ``[0, 1]`` (the paper gives
none; without a thermal term it does not matter).

A *point* is one ``(M, D)`` pair: the main point ``(measurements, noise)``,
then the measurement sweep (figure 4, each ``M`` at the main ``D``) and the
noise sweep (figure 5a, each ``D`` at the main ``M``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..errors import IdentifyError
from ..grid import Grid, n_cells
from ..methods import DAMPED_METHODS, METHODS
from ..profiles import PROFILES

#: The study builds the dense regressor S (N x N) in every worker: 200 MB at L = 100.
MAX_LEVELS = 100
#: Noise amplitudes of the default noise sweep (um); the paper uses 10 and 20.
NOISE_SWEEP = (0.0, 5.0, 10.0, 20.0, 40.0)


def default_measurement_sweep(n_points: int) -> tuple[int, ...]:
    """Multiples of 50 below ``N`` (``50 .. 450`` at L = 30), or ten even steps for small N."""
    if n_points > 100:
        return tuple(range(50, n_points, 50))
    return tuple(sorted({max(1, round(n_points * k / 10)) for k in range(1, 11)}))


def default_noise_sweep() -> tuple[float, ...]:
    return NOISE_SWEEP


@dataclass(frozen=True)
class StudySetup:
    """Settings of one study; :meth:`check` raises :class:`IdentifyError` on bad values.

    ``noise`` is ``D`` (um), the width of the uniform noise interval;
    ``validation_points`` the length of the random validation input
    (figure 6).  Runs are seeded from ``seed`` and their run index only.
    """

    profile: str = "random"
    levels: int = 30
    measurements: int = 300
    runs: int = 1000
    noise: float = 10.0
    seed: int = 0
    methods: tuple[str, ...] = field(default_factory=lambda: tuple(DAMPED_METHODS))
    sweep_measurements: tuple[int, ...] = ()
    sweep_noise: tuple[float, ...] = ()
    validation_points: int = 500

    def __post_init__(self) -> None:
        object.__setattr__(self, "methods", tuple(self.methods))
        object.__setattr__(self, "sweep_measurements", tuple(self.sweep_measurements))
        object.__setattr__(self, "sweep_noise", tuple(float(d) for d in self.sweep_noise))
        self.check()

    @property
    def grid(self) -> Grid:
        return Grid(self.levels, 0.0, 1.0)

    @property
    def n_points(self) -> int:
        """``N``: inputs of the damped oscillation (cells plus the bias)."""
        return n_cells(self.levels) + 1

    def check(self) -> None:
        if self.profile not in PROFILES:
            raise IdentifyError(f"unknown profile {self.profile!r}; choose from {', '.join(PROFILES)}")
        if isinstance(self.levels, bool) or not isinstance(self.levels, int) or not 1 <= self.levels <= MAX_LEVELS:
            raise IdentifyError(
                f"levels must be a whole number from 1 to {MAX_LEVELS} (the study keeps the dense "
                f"N x N regressor in every worker), got {self.levels!r}"
            )
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise IdentifyError(f"the number of runs must be at least 1, got {self.runs!r}")
        if isinstance(self.validation_points, bool) or self.validation_points < 1:
            raise IdentifyError(f"validation input needs at least 1 point, got {self.validation_points!r}")
        for m in (self.measurements, *self.sweep_measurements):
            if isinstance(m, bool) or not isinstance(m, int) or not 1 <= m <= self.n_points:
                raise IdentifyError(
                    f"number of measurements M={m} must be between 1 and N={self.n_points} (L={self.levels})"
                )
        for d in (self.noise, *self.sweep_noise):
            if not (math.isfinite(d) and d >= 0):
                raise IdentifyError(f"noise amplitude D must be a finite number >= 0, got {d!r}")
        if not self.methods:
            raise IdentifyError("no methods to compare")
        for name in self.methods:
            if name not in DAMPED_METHODS:
                what = (f"method {name!r} does not apply to the study's damped oscillation" if name in METHODS
                        else f"unknown method {name!r}")
                raise IdentifyError(f"{what}; choose from {', '.join(DAMPED_METHODS)}")
        if len(set(self.methods)) != len(self.methods):
            raise IdentifyError("a method is listed twice")

    def points(self) -> list[tuple[int, float]]:
        """Every distinct ``(M, D)`` to simulate, the main point first."""
        pts = [(self.measurements, float(self.noise))]
        pts += [(m, float(self.noise)) for m in self.sweep_measurements]
        pts += [(self.measurements, d) for d in self.sweep_noise]
        return list(dict.fromkeys(pts))

    def trials(self) -> list[tuple[int, float, int]]:
        """Every ``(M, D, run)`` to simulate."""
        return [(m, d, r) for (m, d) in self.points() for r in range(self.runs)]
