"""Timings of the matrix-free operator, the square solves and the forward model.

Run as ``python benchmarks/operator_timing.py``; prints a Markdown table
(milliseconds, medians of repeated runs) for the damped oscillation with
the thermal point at L = 30, 100, 200, and an 83,600-point random input at
L = 40 (the size of issue 9's FORC data).
"""

from __future__ import annotations

import time

import numpy as np

from identify import damped_oscillation, random_input
from identify.operators import RegressorOperator
from identify.square import SquareSolver, sparse_inverse

from rig.bench.cases import simulated_actuator as vo2_actuator


def median_ms(f, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def row(label: str, levels: int, v: np.ndarray, square: bool) -> list[str]:
    model = vo2_actuator(levels)
    grid = model.grid
    op = RegressorOperator(grid, v, True)
    rng = np.random.default_rng(0)
    w, r = rng.normal(size=op.shape[1]), rng.normal(size=op.shape[0])
    cells = [
        label, f"{op.shape[0]:,}", f"{op.increments.nnz:,}",
        f"{median_ms(lambda: RegressorOperator(grid, v, True), 3):.1f}",
        f"{median_ms(lambda: op.matvec(w)):.2f}",
        f"{median_ms(lambda: op.rmatvec(r)):.2f}",
        f"{median_ms(lambda: model.predict(v), 3):.1f}",
    ]
    if square:
        solver = SquareSolver(op)
        cells += [
            f"{median_ms(lambda: SquareSolver(op), 3):.1f}",
            f"{median_ms(lambda: solver.solve(r)):.2f}",
            f"{median_ms(lambda: sparse_inverse(solver), 3):.0f}",
        ]
    else:
        cells += ["-", "-", "-"]
    return cells


def main() -> None:
    headers = ["input", "n", "nnz(E)", "build", "S w", "Sᵀ r", "predict", "factor", "S⁻¹ b", "S⁻¹ itself"]
    rows = []
    for levels in (30, 100, 200):
        v = damped_oscillation(vo2_actuator(levels).grid, thermal_term=True)
        rows.append(row(f"damped oscillation, L = {levels}", levels, v, True))
    v = random_input(vo2_actuator(40).grid, 83_600, seed=0)
    rows.append(row("random, L = 40", 40, v, False))
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    for cells in rows:
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
