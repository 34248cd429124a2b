"""What a ``rig identify`` fit will cost, estimated before it runs, and the limits above which it is refused.

A fit's time and memory grow with the grid's parameters ``P = L(L+1)/2 + 2``,
the applied points ``n`` and the measured rows ``M``, in a way that depends
on the method and its path (docs/explanation/methods.md).  Each method
states its own rough model (:meth:`identify.methods.Method.cost`), with
constants set from measurements on the 2-core development machine
(``benchmarks/identify_cost.py`` prints the measured figures beside the
estimates); :func:`estimate_fit` adds what every fit has.  The time of an active-set or
iterative solver depends on the data (how many cells the fit leaves free),
not only on the sizes: trust the time to within a factor of ten either way
and the memory to within a factor of three, which is what it is for --
telling a two-second fit from a two-hour one, and 100 MB from 40 GB, before
either starts.

The limits (docs/reference/limits.md), beyond which ``rig identify`` refuses
unless ``--yes``: :data:`MAX_SECONDS` estimated fitting time per file and
:data:`MAX_MEMORY_BYTES` estimated peak memory.  ``--levels 10000`` on any
run asks for 50 million parameters: about 4 GB before the first iteration (as measured: 4 GB
after five minutes of ``ls``).
"""

from __future__ import annotations

from dataclasses import dataclass

from identify.methods import METHODS

from .limits import Exceeded, format_bytes, format_duration

#: Longest estimated fit, per file, without --yes (s).
MAX_SECONDS = 30 * 60.0
#: Largest estimated peak memory without --yes (bytes).
MAX_MEMORY_BYTES = 4e9
#: A fit estimated to take longer than this gets a progress line with the time left (s).
PROGRESS_AFTER_S = 2.0

#: The process itself: interpreter, numpy, scipy, h5py, the methods (bytes).
BASE_BYTES = 90e6
#: Per parameter: the grid's and the operator's per-cell arrays, the solution and its work copies (bytes).
BYTES_PER_PARAMETER = 80
#: Per applied point: inputs, outputs, the memory replay's Everett terms (bytes).
BYTES_PER_POINT = 200


def n_parameters(levels: int, thermal_term: bool = True) -> int:
    """``P``: the cells of L levels, ``mu0`` and (with the thermal term) ``c_d``."""
    return levels * (levels + 1) // 2 + 1 + int(thermal_term)


@dataclass(frozen=True)
class FitCost:
    """An estimate: ``seconds`` of fitting and ``memory_bytes`` of peak resident memory."""

    method: str
    levels: int
    parameters: int
    points: int
    measured: int
    seconds: float
    memory_bytes: float

    @property
    def memory_mb(self) -> float:
        return self.memory_bytes / 1e6

    def describe(self) -> str:
        """One line: what is fitted and what it will cost."""
        return (f"{self.method} on L = {self.levels} ({self.parameters:,} parameters), {self.measured:,} measured "
                f"of {self.points:,} points: about {format_duration(self.seconds)} and "
                f"{format_bytes(self.memory_bytes)} (estimated)")

    def exceeded(self) -> list[Exceeded]:
        """The documented limits this fit is over."""
        out = []
        if self.seconds > MAX_SECONDS:
            out.append(Exceeded("estimated time", format_duration(self.seconds), format_duration(MAX_SECONDS)))
        if self.memory_bytes > MAX_MEMORY_BYTES:
            out.append(Exceeded("estimated memory", format_bytes(self.memory_bytes), format_bytes(MAX_MEMORY_BYTES)))
        return out


def estimate_fit(method: str, levels: int, points: int, measured: int, *, square: bool = False,
                 thermal_term: bool = True) -> FitCost:
    """The estimated cost of fitting ``method`` on L = ``levels`` to ``measured`` of ``points`` applied points.

    ``square``: the inputs are the square damped-oscillation design (as
    many points as parameters), which the output-space paths use.
    """
    p = n_parameters(levels, thermal_term)
    seconds, working = METHODS[method].cost(p, points, measured, square)
    build = 3e-6 * points + 2e-7 * p  # the memory replay and the prefix tables
    memory = BASE_BYTES + BYTES_PER_PARAMETER * p + BYTES_PER_POINT * points + working
    return FitCost(method, levels, p, points, measured, seconds + build, memory)


def job_cost(job) -> FitCost:
    """The estimate for a planned ``rig identify`` job (:class:`rig.reidentify.IdentifyJob`)."""
    levels = job.grid.levels
    points = int(job.inputs.size)
    square = points == n_parameters(levels, job.thermal_term)
    return estimate_fit(job.method, levels, points, int(job.rows.size), square=square,
                        thermal_term=job.thermal_term)
