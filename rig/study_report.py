"""``rig study`` output: the JSON object and the tables with the paper's numbers beside ours."""

from __future__ import annotations

import math
from typing import Any

from identify.study import METRICS, PAPER, Finding, PointSummary, StudySummary
from identify.study.paper import label

from .output import format_table

NAN = float("nan")


def _methods_dict(point: PointSummary) -> dict[str, dict[str, Any]]:
    out = {}
    for name in point.per_run:
        m = point.method(name)
        out[name] = {**{k: m.mean[k] for k in METRICS}, "failures": m.failures}
    return out


def _point_dict(point: PointSummary) -> dict[str, Any]:
    return {"measurements": point.measurements, "noise": point.noise, "methods": _methods_dict(point)}


def paper_figures(profile: str) -> dict[str, Any]:
    """The paper's numbers that apply to ``profile`` (and the run times of figure 5b)."""
    return {**PAPER.get(profile, {}), "seconds_matlab": PAPER["seconds"]}


def study_json(summary: StudySummary, found: list[Finding], plots: list[str]) -> dict[str, Any]:
    """The ``rig study --json`` object (schema in docs/reference/commands/study.md)."""
    s, p = summary.setup, summary.main
    sp = p.sparsity.mean(axis=0)
    return {
        "profile": s.profile,
        "levels": s.levels,
        "measurements": s.measurements,
        "runs": s.runs,
        "noise": s.noise,
        "methods": _methods_dict(p),
        "seed": s.seed,
        "n_points": s.n_points,
        "validation_points": s.validation_points,
        "sparsity": {"q_small": sp[0], "q_order_small": sp[1], "q_max": sp[2], "q_order_max": sp[3],
                     "threshold": 0.01, "n": s.n_points},
        "sweeps": {
            "measurements": [_point_dict(q) for q in summary.measurement_sweep],
            "noise": [_point_dict(q) for q in summary.noise_sweep],
        },
        "paper": paper_figures(s.profile),
        "findings": [f.__dict__ for f in found],
        "plots": plots,
    }


def _ratio(a: float, b: float) -> float:
    return a / b if b and math.isfinite(a) and math.isfinite(b) else NAN


def _main_tables(summary: StudySummary) -> list[str]:
    p, profile = summary.main, summary.setup.profile
    paper = PAPER.get(profile, {})
    names = list(p.per_run)
    ls = p.method("ls").mean if "ls" in names else None
    validation = PAPER["random"]["validation_rmse"] if profile == "random" else {}
    rows_a, rows_b = [], []
    for name in names:
        m = p.method(name).mean
        rows_a.append([
            name, m["model_rmse"], paper.get("model_rmse", {}).get(name, NAN),
            m["model_max"], paper.get("model_max", {}).get(name, NAN),
            m["validation_rmse"], validation.get(name, NAN),
        ])
        paper_ls = {"ls": 1.0} if profile == "random" else {}
        rows_b.append([
            name, m["density_rmse"],
            _ratio(m["density_rmse"], ls["density_rmse"]) if ls else NAN,
            {**paper_ls, **paper.get("density_rmse_vs_ls", {})}.get(name, NAN),
            _ratio(m["model_rmse"], ls["model_rmse"]) if ls else NAN,
            {**paper_ls, **paper.get("model_rmse_vs_ls", {})}.get(name, NAN),
            m["seconds"], PAPER["seconds"].get(name, NAN),
        ])
    return [
        "Modelling error, normalised by the true output's range (Tables 1-2, figures 4b and 6):",
        format_table(["method", "model_rmse", "paper", "model_max", "paper", "validation_rmse", "paper"], rows_a),
        "",
        "Density RMSE (um, figure 4a), ratios to Least Squares (figure 4), fit time (figure 5b):",
        format_table(["method", "density_rmse", "vs_ls", "paper", "model_vs_ls", "paper", "seconds",
                      "paper_matlab_s"], rows_b),
    ]


def _sweep_table(points: list[PointSummary], key: str, metric: str) -> str:
    names = list(points[0].per_run)
    rows = [[getattr(q, key), *(q.mean(n, metric) for n in names)] for q in points]
    return format_table([key, *names], rows)


def _finding_line(f: Finding) -> str:
    verdict = f.verdict.upper() if f.verdict in ("disagrees", "missed") else f.verdict
    ref = "paper" if f.kind == "paper" else "target"
    return f"  {verdict:<12} {f.claim} [{f.source}]\n               {ref}: {f.paper}; ours: {f.ours}"


def study_text(summary: StudySummary, found: list[Finding], plots: list[str]) -> str:
    """The tables and findings as printed by ``rig study``."""
    s, p = summary.setup, summary.main
    lines = [
        f"Section 4 of Zhang et al. (2016), {s.profile} profile: L = {s.levels} (N = {s.n_points} points), "
        f"M = {s.measurements} measured, noise uniform on [-{s.noise / 2:g}, {s.noise / 2:g}] um "
        f"(D = {s.noise:g}), {s.runs} runs, seed {s.seed}. Means over runs; 'paper' columns are the "
        "paper's published figures ('-': not given).",
        "",
        *_main_tables(summary),
        "",
    ]
    sp = p.sparsity.mean(axis=0)
    ref = PAPER["random"]["sparsity"]
    lines.append(
        f"DCT sparsity (figure 3): of the N = {s.n_points} coefficients, {sp[0]:.1f} of q and {sp[1]:.1f} of "
        f"q_order are below 1 % of the largest (paper, one random-profile example of N = {ref['n']}: "
        f"{ref['q_small']} and {ref['q_order_small']}); largest |q| {sp[2]:.1f}, |q_order| {sp[3]:.1f} "
        f"(paper {ref['q_max']}, {ref['q_order_max']})."
    )
    for name, errors in p.errors.items():
        if errors:
            lines.append(f"WARNING: {name} failed on {len(errors)} of {p.runs} runs (first: {errors[0]})")
    if summary.measurement_sweep:
        for metric, fig in (("model_rmse", "4b"), ("density_rmse", "4a"), ("seconds", "5b"),
                            ("validation_rmse", "6")):
            lines += ["", f"Measurement sweep (figure {fig}), {metric} at D = {s.noise:g}:",
                      _sweep_table(summary.measurement_sweep, "measurements", metric)]
    if summary.noise_sweep:
        for metric, fig in (("density_rmse", "5a"), ("model_rmse", "5a")):
            lines += ["", f"Noise sweep (figure {fig}), {metric} at M = {s.measurements}:",
                      _sweep_table(summary.noise_sweep, "noise", metric)]
    paper_found = [f for f in found if f.kind == "paper"]
    targets = [f for f in found if f.kind == "target"]
    disagree = sum(f.verdict == "disagrees" for f in paper_found)
    lines += ["", f"The paper's claims, tested by paired comparison over the runs ({disagree} of "
              f"{len(paper_found)} DISAGREE with our results):"]
    lines += [_finding_line(f) for f in paper_found] or ["  (none: the methods they compare were not run)"]
    if targets:
        lines += ["", f"Targets for {label('smooth_nn')}:"]
        lines += [_finding_line(f) for f in targets]
    if plots:
        lines += ["", "Figures: " + ", ".join(plots)]
    return "\n".join(lines)
