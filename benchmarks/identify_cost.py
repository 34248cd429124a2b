"""What an identification costs, measured, to check the estimate ``rig identify`` states before a long fit.

    python benchmarks/identify_cost.py [--methods ls,smooth_nn,...] [--json]

Each (method, design, L, n) is fitted in a fresh process (so its peak memory
is its own): a random input of ``n`` points on L levels (every point
measured; the general design, as an imported trace), and the damped
oscillation with the thermal point (the square design).  Printed: the
fit's wall time (problem built and fitted), the process's peak resident
memory, and beside them the estimate of :mod:`rig.budget.identification`
with the ratio measured / estimated.  The estimate's constants were set
from a run of this script; the ratios say how far to trust it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

#: ``(design, L, n)``: n is the number of points of a random input (None: the damped oscillation's).
CASES = (("random", 30, 467), ("random", 60, 467), ("random", 100, 467), ("random", 200, 467),
         ("random", 40, 20_000), ("damped", 30, None), ("damped", 100, None))

CHILD = """
import json, resource, sys, time
import numpy as np
from identify import Grid, Problem, damped_oscillation, make_method, random_input
from rig.bench.cases import simulated_actuator
design, levels, n, method = json.loads(sys.argv[1])
truth = simulated_actuator(levels)
v = damped_oscillation(truth.grid, thermal_term=True) if design == "damped" else random_input(truth.grid, n, seed=1)
y = truth.predict(v) + np.random.default_rng(0).uniform(-0.025, 0.025, v.size)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
start = time.perf_counter()
make_method(method).fit(Problem.build(truth.grid, v, y, np.arange(v.size), thermal_term=True))
seconds = time.perf_counter() - start
print(json.dumps({"seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "baseline_mb": base, "n": int(v.size)}))
"""


def measure(design: str, levels: int, n: int | None, method: str, timeout: float) -> dict:
    try:
        done = subprocess.run([sys.executable, "-c", CHILD, json.dumps([design, levels, n, method])],
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"status": f"timeout after {timeout:g} s"}
    if done.returncode != 0:
        return {"status": (done.stderr.strip().splitlines() or ["failed"])[-1]}
    return {"status": "ok", **json.loads(done.stdout.strip().splitlines()[-1])}


def main() -> None:
    from rig.budget.identification import estimate_fit

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--methods", default="ls,cs_order_nn,smooth_nn")
    parser.add_argument("--timeout", type=float, default=300.0, help="give up on one case after this long (s)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows = []
    print(f"load average {os.getloadavg()[0]:.2f}", file=sys.stderr)
    for design, levels, n in CASES:
        for method in args.methods.split(","):
            square = design == "damped"
            if method in ("cs", "cs_order", "cs_order_nn", "cs_nodct") and not square:
                continue
            got = measure(design, levels, n, method, args.timeout)
            points = got.get("n", n)
            est = estimate_fit(method, levels, points or 0, points or 0, square=square)
            rows.append({"method": method, "design": design, "levels": levels, "n": points, **got,
                         "estimated_s": est.seconds, "estimated_mb": est.memory_mb})
            r = rows[-1]
            if r["status"] == "ok":
                print(f"{method:12s} {design:7s} L={levels:4d} n={r['n']:7d}  {r['seconds']:8.2f} s "
                      f"(est {r['estimated_s']:8.2f}, x{r['seconds'] / r['estimated_s']:5.2f})  "
                      f"{r['peak_mb']:7.0f} MB (est {r['estimated_mb']:7.0f}, x{r['peak_mb'] / r['estimated_mb']:5.2f})",
                      file=sys.stderr)
            else:
                print(f"{method:12s} {design:7s} L={levels:4d}: {r['status']}", file=sys.stderr)
    print(f"load average {os.getloadavg()[0]:.2f}", file=sys.stderr)
    if args.json:
        print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
