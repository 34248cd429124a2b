"""What a ``rig identify`` fit will cost, estimated before it runs, and the limits above which it is refused.

A fit's time and memory grow with the grid's parameters ``P = L(L+1)/2 + 2``,
the applied points ``n`` and the measured rows ``M``, in a way that depends
on the method and its path (docs/explanation/methods.md).  :func:`estimate_fit`
is a rough model of each path, with constants set from measurements on the
2-core development machine (``benchmarks/identify_cost.py`` prints the
measured figures beside the estimates).  The time of an active-set or
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
#: ``smooth_nn``'s paths (identify.methods.smooth_nn): the dense normal equations up to this many cells.
SMOOTH_NORMAL_CELLS = 2016
#: ``ls`` builds dense rows of ``S`` up to this many entries (identify.methods.nnls.DENSE_LH_ENTRIES).
LS_DENSE_ENTRIES = 500_000
#: Methods that need the square damped-oscillation design.
SQUARE_METHODS = ("cs", "cs_order", "cs_order_nn", "cs_nodct")


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


def _seconds_and_bytes(method: str, p: int, n: int, m: int, square: bool) -> tuple[float, float]:
    """The method's own time (s) and working memory (bytes) beyond the per-parameter and per-point arrays.

    Constants from measured fits (docs/results: speed and scale, the FORC file, and
    ``benchmarks/identify_cost.py``): ``ls`` at L = 60-1000 on 467 rows, L = 100/200 on the damped
    oscillation, L = 40 on the FORC file; ``smooth_nn`` at L = 30/60 (normal equations), 100 (iterative),
    100/200 (output space); the square-design methods at L = 30, 100, 200.
    """
    cells = p - 2
    if method == "ls":
        if min(m, p) * p <= LS_DENSE_ENTRIES:  # scipy's NNLS on dense rows
            return 2e-9 * m * p * min(m, p), 24.0 * min(m, p) * p
        # Lawson-Hanson on operator products: one product per step, a thin QR of the passive columns
        return 1e-7 * m * p + 3e-10 * m * min(m, p) ** 2, 8.0 * (m * min(m, p, 2000) + 4 * p)
    if method == "smooth_nn":
        if cells <= SMOOTH_NORMAL_CELLS:  # dense normal equations, GCV's eigendecomposition, the QP
            return 2e-9 * p ** 3 + 3e-7 * m * p + 0.3, 64.0 * p * p + 8.0 * min(m * p, 4e6)
        if square:  # output space: sparse factorisations along the weight path, then Clarabel
            return 5e-6 * n ** 1.5, 2e3 * n
        # L-BFGS-B on operator products along a hold-out path of weights
        return 1e-4 * (n + p) ** 1.5, 200.0 * p
    if method in SQUARE_METHODS:  # sparse S^-1; basis pursuit's dense basis for M <= 1000
        return 2e-4 * n + 2e-9 * min(m, 1000) ** 3, 2e3 * n + 8.0 * min(m, 1000) ** 2
    if method == "everett":  # second differences of the interpolated FORC surface
        return 1e-6 * n + 1e-5 * p, 8.0 * n
    return 1e-6 * m * p, 8.0 * m * p  # a method added later: the size of A S


def estimate_fit(method: str, levels: int, points: int, measured: int, *, square: bool = False,
                 thermal_term: bool = True) -> FitCost:
    """The estimated cost of fitting ``method`` on L = ``levels`` to ``measured`` of ``points`` applied points.

    ``square``: the inputs are the square damped-oscillation design (as
    many points as parameters), which the output-space paths use.
    """
    p = n_parameters(levels, thermal_term)
    seconds, working = _seconds_and_bytes(method, p, points, measured, square)
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
