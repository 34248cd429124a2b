"""Measure one (case, method, solver) in this process; run as ``python -m rig.bench.worker SPEC``.

``SPEC`` is a JSON object ``{"levels", "measurements", "seed", "method",
"solver", "repeats", "budget_s"}``; ``solver`` is ``"fast"`` (the method's
default settings) or ``"dense"`` (``solver="dense"``, the reference).  Prints one JSON object: the timed runs
(end to end: building the problem from the raw data plus the fit; wall
time, and the process's CPU time, which a busy machine disturbs less),
the peak memory and the fitted parameters.  Every run builds its problem on
one :class:`~identify.regressor_design.Design`, as a user re-fitting on the same
design does: ``first_s`` is the first run's time, a cold start (the
design's operator and square solver, and every per-grid cache, still to be
built), where the later runs re-fit on the same design.

Memory, in MB:

* ``peak_mb`` -- ``ru_maxrss`` of this process after every run: the whole
  process's peak resident memory, interpreter and libraries included
  (``baseline_mb`` is the same before the first fit);
* ``traced_mb`` -- the ``tracemalloc`` peak of one extra run: every Python
  and numpy allocation of the fit, but not memory allocated inside
  compiled solvers (SuperLU, Clarabel, LAPACK work arrays).

The traced run is separate because tracing slows allocation-heavy code.
"""

from __future__ import annotations

import json
import resource
import sys
import time
import tracemalloc

import numpy as np

from identify import Problem, make_method
from identify.regressor_design import Design

from .cases import Case


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


def measure(spec: dict) -> dict:
    case = Case(int(spec["levels"]), int(spec["measurements"]), int(spec.get("seed", 0)))
    truth, v, _, noisy, rows = case.data()
    repeats = max(1, int(spec.get("repeats", 5)))
    budget = float(spec.get("budget_s", 60.0))

    # the fast path is every method's default; the dense reference is its solver="dense"
    settings = {"solver": "dense"} if spec["solver"] == "dense" else {}
    make_method(spec["method"], **settings)  # a method without a dense reference fails here, untimed

    design = Design(truth.grid, v, thermal_term=True)  # builds nothing yet: the first run does

    def run() -> np.ndarray:
        problem = Problem.on(design, noisy, rows)
        return make_method(spec["method"], **settings).fit(problem).parameters_

    if spec["solver"] == "dense":
        import cvxpy  # noqa: F401  (the dense path imports it on first use; not part of the timing)
    import scipy.fft  # noqa: F401  (nor are the imports the fast paths make on first use)
    import scipy.optimize  # noqa: F401

    baseline = _maxrss_mb()
    seconds: list[float] = []
    cpu: list[float] = []
    w = None
    while len(seconds) < repeats and (not seconds or sum(seconds) < budget):
        start, start_cpu = time.perf_counter(), time.process_time()
        w = run()
        seconds.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    peak = _maxrss_mb()
    tracemalloc.start()
    run()
    _, traced = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {
        "seconds": seconds,
        "median_s": float(np.median(seconds)),
        "first_s": seconds[0],
        "cpu_s": float(np.median(cpu)),
        "peak_mb": peak,
        "baseline_mb": baseline,
        "traced_mb": traced / 2**20,
        "parameters": [float(x) for x in w],
    }


def main() -> None:
    spec = json.loads(sys.argv[1])
    try:
        result = {"status": "ok", **measure(spec)}
    except Exception as exc:  # reported, not raised: one failing case must not stop the bench
        result = {"status": f"{type(exc).__name__}: {exc}"}
    sys.stdout.write(json.dumps(result) + "\n")


if __name__ == "__main__":
    main()
