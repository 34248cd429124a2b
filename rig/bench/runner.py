"""Run the benchmark: every (case, method), fast path and dense reference, each in a fresh process.

A fresh process per measurement keeps the peak-memory figure (``ru_maxrss``)
about that measurement alone; the problem is rebuilt from the case's seed
in each, so both paths see the same data.  The accuracy of the fast path is
judged here, from the two parameter vectors, on the outputs they predict at
all ``N + 1`` applied inputs:

* ``fast_rmse_um`` / ``dense_rmse_um``: the modelling RMSE, the model's
  output against the noise-free simulated actuator;
* ``rmse_rel_diff``: RMS of (fast model's output - dense model's output)
  divided by ``dense_rmse_um`` -- how far apart the two results are, in
  units of the modelling error (the issue's target: at most 0.01).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterable

import numpy as np

from identify.operators import RegressorOperator

from .cases import Case


def measure(case: Case, method: str, solver: str, repeats: int, budget_s: float,
            timeout_s: float, threads: int | None) -> dict:
    """One worker process (:mod:`rig.bench.worker`); its JSON result, or a status on failure."""
    spec = {"levels": case.levels, "measurements": case.measurements, "seed": case.seed,
            "method": method, "solver": solver, "repeats": repeats, "budget_s": budget_s}
    env = dict(os.environ)
    if threads is not None:
        for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            env[name] = str(threads)
    try:
        done = subprocess.run(
            [sys.executable, "-m", "rig.bench.worker", json.dumps(spec)],
            capture_output=True, text=True, timeout=timeout_s, env=env, check=False,
        )
    except subprocess.TimeoutExpired:
        return {"status": f"timeout after {timeout_s:g} s"}
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"status": f"worker failed ({done.returncode}): {last}"}
    return json.loads(lines[-1])


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def compare(case: Case, fast: dict, dense: dict | None) -> dict:
    """Modelling RMSE of each result and their difference (see the module docstring)."""
    truth, v, clean, _, _ = case.data()
    op = RegressorOperator(truth.grid, v, True)
    out: dict = {"fast_rmse_um": None, "dense_rmse_um": None, "rmse_rel_diff": None}
    if fast.get("status") != "ok":
        return out
    fast_out = op.matvec(np.asarray(fast["parameters"]))
    out["fast_rmse_um"] = _rms(fast_out - clean)
    if dense is not None and dense.get("status") == "ok":
        dense_out = op.matvec(np.asarray(dense["parameters"]))
        out["dense_rmse_um"] = _rms(dense_out - clean)
        out["rmse_rel_diff"] = _rms(fast_out - dense_out) / out["dense_rmse_um"]
    return out


def bench(
    cases: Iterable[Case],
    methods: Iterable[str],
    dense_up_to: int = 30,
    repeats: int = 5,
    budget_s: float = 60.0,
    timeout_s: float = 900.0,
    threads: int | None = None,
) -> list[dict]:
    """One row per (case, method), in the ``rig bench --json`` shape plus details."""
    rows = []
    for case in cases:
        for method in methods:
            fast = measure(case, method, "fast", repeats, budget_s, timeout_s, threads)
            dense = None
            if case.levels <= dense_up_to:
                dense = measure(case, method, "dense", repeats, budget_s, timeout_s, threads)
            ok = fast.get("status") == "ok"
            dense_ok = dense is not None and dense.get("status") == "ok"
            rows.append({
                "levels": case.levels,
                "measurements": case.measurements,
                "points": case.points,
                "method": method,
                "fast_s": fast.get("median_s") if ok else None,
                "dense_s": dense.get("median_s") if dense_ok else None,
                "ratio": dense["median_s"] / fast["median_s"] if ok and dense_ok else None,
                "peak_mb": fast.get("peak_mb") if ok else None,
                **compare(case, fast, dense),
                "fast_cold_s": fast.get("first_s") if ok else None,
                "fast_cpu_s": fast.get("cpu_s") if ok else None,
                "dense_cpu_s": dense.get("cpu_s") if dense_ok else None,
                "traced_mb": fast.get("traced_mb") if ok else None,
                "baseline_mb": fast.get("baseline_mb") if ok else None,
                "dense_peak_mb": dense.get("peak_mb") if dense_ok else None,
                "runs": len(fast.get("seconds", [])),
                "status": fast.get("status"),
                "dense_status": None if dense is None else dense.get("status"),
            })
    return rows
