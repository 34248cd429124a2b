"""The work of the benchmark's worker processes: calibrate one effect, record and diagnose one case.

Module-level functions of an importable module, as :func:`rig.parallel.run_parallel`
needs; each returns a JSON-safe dict and reports its errors instead of
raising them, so that one failing case does not stop the benchmark.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

from benchmarks.blind.scoring import oracle_separation, wants_oracle

from .generate import Bench, Case, calibrate
from .oracle import true_signals

_BENCHES: dict[int, Bench] = {}


def _bench(seed: int) -> Bench:
    """The seed's bench, kept for the next jobs of this worker (the clean device's residual is reused)."""
    if seed not in _BENCHES:
        if len(_BENCHES) >= 4:
            _BENCHES.pop(next(iter(_BENCHES)))
        _BENCHES[seed] = Bench(seed)
    return _BENCHES[seed]


# ====================================================================== jobs (run in the workers)
def calibration_job(job: tuple[int, str, float]) -> dict[str, Any]:
    seed, family, level = job
    try:
        return calibrate(_bench(seed), family, level).to_json()
    except Exception as exc:  # noqa: BLE001  (reported, not raised: one case must not stop the benchmark)
        return {"seed": seed, "family": family, "level": level, "status": f"{type(exc).__name__}: {exc}",
                "form": None, "strength": None, "gap_um": None, "attempt": None}


def diagnose(fit: Path, check: Path, cold: bool, timeout_s: float = 900.0) -> tuple[dict[str, Any] | None, str, float]:
    """``rig diagnose --fit FIT --check CHECK --json``: (its JSON or None, error text, wall seconds)."""
    args = ["diagnose", "--fit", str(fit), "--check", str(check), "--json"]
    t0 = time.perf_counter()
    if cold:
        try:
            done = subprocess.run([sys.executable, "-m", "rig", *args], capture_output=True, text=True,
                                  timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired:
            return None, f"timeout after {timeout_s:g} s", time.perf_counter() - t0
        out, err, code = done.stdout, done.stderr, done.returncode
    else:
        from click.testing import CliRunner

        from rig.cli import cli

        res = CliRunner().invoke(cli, args, catch_exceptions=True)
        out, code = res.stdout, res.exit_code
        err = res.stderr if res.stderr else (repr(res.exception) if res.exception else "")
    seconds = time.perf_counter() - t0
    if code != 0:
        return None, f"exit {code}: {(err.strip().splitlines() or ['no message'])[-1]}", seconds
    try:
        return json.loads(out), "", seconds
    except json.JSONDecodeError as exc:
        return None, f"not JSON: {exc}", seconds


def read_verdict(js: dict[str, Any]) -> dict[str, Any]:
    """The fields of ``rig diagnose --json`` the benchmark reads, and nothing else."""
    v = js.get("verdict") or {}
    effects = v.get("effects")
    if effects is None:
        effects = [v["effect"]] if v.get("effect") else []
    cands = []
    for c in js.get("candidates") or []:
        cands.append({k: c.get(k) for k in ("effect", "shrink", "share_closed", "rmse_um", "z", "visible")})
    return {"status": v.get("status"), "effect": v.get("effect"), "effects": list(effects),
            "rivals": list(v.get("rivals") or []),
            "shrink": v.get("shrink"), "share_closed": v.get("share_closed"), "reason": v.get("reason"),
            "candidates": cands}


def case_job(job: dict[str, Any]) -> dict[str, Any]:
    case = Case(**job["case"])
    cals: dict[str, dict[str, Any]] = job["cals"]
    row: dict[str, Any] = {"key": case.key, "case": asdict(case), "label": case.label, "kind": case.kind}
    keep = job.get("keep")
    directory = Path(keep) / case.key if keep else Path(tempfile.mkdtemp(prefix="withheld-"))
    try:
        bad = [f for f in case.effects if cals[f].get("strength") is None]
        if bad:
            row.update(status="skipped", error=f"no calibration for {', '.join(bad)}")
            return row
        bench = _bench(case.seed)
        active = {f: (cals[f]["form"], float(cals[f]["strength"])) for f in case.effects}
        t0 = time.perf_counter()
        if len(case.effects) > 1:
            row["gap_um"] = bench.gap_um(active)
        elif case.effects:
            row["gap_um"] = cals[case.effects[0]]["gap_um"]
        else:
            row["gap_um"] = 0.0
        row["gap_sigma"] = row["gap_um"] / bench.sigma_um
        row["alone_gap_sigma"] = {f: cals[f]["gap_um"] / bench.sigma_um for f in case.effects}
        fit, check = bench.record(active, directory, case.label, case.level)
        row["record_s"] = time.perf_counter() - t0
        js, err, seconds = diagnose(fit, check, bool(job.get("cold")))
        row["diagnose_s"] = seconds
        if js is None:
            row.update(status="error", error=err)
            return row
        row.update(status="ok", verdict=read_verdict(js))
        rival = wants_oracle(case.kind, list(case.effects), row["verdict"])
        if rival is not None:  # is the ambiguity honest? the true signal against the rival, on these sessions
            row["oracle_z"] = oracle_separation(fit, check, list(true_signals(bench, active)["oracle_total"]), rival)
        if keep:
            (directory / "diagnosis.json").write_text(json.dumps(js, indent=1))
        return row
    except Exception as exc:  # noqa: BLE001  (reported, not raised)
        row.update(status="error", error=f"{type(exc).__name__}: {exc}")
        return row
    finally:
        if not keep:
            shutil.rmtree(directory, ignore_errors=True)
