"""Median fit time of smooth_nn against ls on the paper's set-up (L = 30, M = 300, D = 10).

    python benchmarks/smooth_nn_timing.py [--levels L] [--measurements M] [--problems K]

Prints the median over K problems (random profile, fresh noise and rows) of
each method's ``seconds_`` and their ratio, both measured in this process.
Run it with ``OPENBLAS_NUM_THREADS=1`` on a shared machine.
"""

from __future__ import annotations

import argparse

import numpy as np

from identify import Grid, Problem, choose_rows, damped_oscillation, make_method
from identify.regressor_design import Design
from identify.profiles import profile
from identify.regressor import regressor_matrix


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, default=30)
    parser.add_argument("--measurements", type=int, default=300)
    parser.add_argument("--problems", type=int, default=30)
    args = parser.parse_args()
    grid = Grid(args.levels, 0.0, 1.0)
    design = Design(grid, damped_oscillation(grid), thermal_term=False)  # every problem's: one operator
    v = design.inputs
    s = regressor_matrix(grid, v, thermal_term=False)
    problems = []
    for k in range(args.problems):
        rng = np.random.default_rng(k)
        y = s @ np.append(profile("random", grid, rng), 0.0) + rng.uniform(-5, 5, v.size)
        rows = choose_rows(v.size, args.measurements, k)
        problems.append(Problem.on(design, y, rows, regressor=s))
    times = {"ls": [], "smooth_nn": []}
    for name in times:
        make_method(name).fit(problems[0])  # warm caches (standard form of the penalty)
    for problem in problems:
        for name, acc in times.items():  # interleaved, so load changes hit both alike
            acc.append(min(make_method(name).fit(problem).seconds_ for _ in range(3)))
    med = {name: float(np.median(t)) for name, t in times.items()}
    print(f"L={args.levels} M={args.measurements}, {args.problems} problems, best of 3 each, median:")
    for name, t in med.items():
        print(f"  {name:<10} {t * 1e3:7.1f} ms")
    print(f"  smooth_nn / ls = {med['smooth_nn'] / med['ls']:.2f}")


if __name__ == "__main__":
    main()
