"""What ``rig diagnose`` says: the ``--json`` object (the issue's contract) and the readable report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from identify.diagnosis import Diagnosis
from identify.diagnosis.binning import Binning
from identify.diagnosis.candidates import summary

from ..output import format_table


def _bins(binning: Binning) -> list[dict[str, Any]]:
    out = []
    for b in binning.bins:
        row = {"lo": b.lo, "hi": b.hi, "mean_um": b.mean_um, "rms_um": b.rms_um, "n": b.n,
               "significant": b.significant}
        if b.label:
            row["label"] = b.label
        out.append(row)
    return out


def to_json(d: Diagnosis, fit: list[str], check: list[str], warnings: list[str],
            drift_monitor: dict[str, Any] | None = None) -> dict[str, Any]:
    """The ``--json`` object: ``baseline``, ``where``, ``candidates``, ``verdict`` (the contract), and
    the extras documented in the README.  The keys keep their ``_um``/``V`` names (the contract);
    their values are in the runs' units, named by ``units``."""
    after = {w.by: w for w in d.where_after} if d.where_after is not None else {}
    chosen = d.chosen
    where = []
    for w in d.where:
        entry: dict[str, Any] = {"by": w.by, "unit": w.unit, "bins": _bins(w)}
        if w.by in after:
            entry["after"] = {"effect": chosen, "bins": _bins(after[w.by])}
        where.append(entry)
    leading = d.score(chosen) if chosen else None
    noise = d.noise
    return {
        "baseline": {
            "rmse_um": d.baseline_rmse_um,
            "noise_floor_um": d.noise_floor_um,
            "ci": list(d.baseline_ci),
            "fit_only_rmse_um": d.fit_only_rmse_um,
            "measurement_noise_um": d.measurement_noise_um,
            "noise_source": noise.source if noise else None,
            "noise_floor_kind": d.floor_kind,
            "noise_detail": noise.detail if noise else None,
            "recalibrated_directions": d.recalibrated,
            "noise_amplification": list(d.amplification),
            "n_points": int(d.points.residual.size),
        },
        "where": where,
        "candidates": [
            {
                "effect": c.effect,
                "rmse_um": c.rmse_um,
                "shrink": c.shrink,
                "ci": list(c.ci),
                "params": c.params,
                "z": c.z,
                "gain_um2": c.gain_um2,
                "share_closed": c.share_closed,
                "visible": c.visible,
                "note": c.note or None,
                "ci_block_bootstrap": list(c.ci_block_bootstrap),
                **({"levels": c.params["levels"]} if "levels" in c.params and c.effect == "resolution" else {}),
            }
            for c in d.candidates
        ],
        "verdict": {
            "status": d.verdict.status,
            "effect": d.verdict.effect,
            "shrink": d.verdict.shrink,
            "contenders": list(d.verdict.contenders),
            "rivals": list(d.verdict.rivals),
            "unassessed": list(d.verdict.unassessed),
            "reason": d.verdict.reason,
            "rmse_with_um": _rmse_with(d, leading),
            "share_closed": d.verdict.share_closed,
            "not_visible": [c.effect for c in d.candidates if not c.visible],
            "model": kept_json(d, fit),
            "effects": list(d.verdict.effects) if d.verdict.status == "explained" else [],
            "steps": [dict(step) for step in d.verdict.steps] if d.verdict.status == "explained" else [],
            "look_alikes": look_alikes(_named(d)),
        },
        "not_assessed": [{"effect": e, "reason": r} for e, r in d.not_assessed],
        "use_clock": use_clock(d),
        "warnings": list(warnings) + list(d.warnings),
        "fit": fit,
        "check": check,
        "grid": {"levels": d.grid.levels, "v_min": d.grid.v_min, "v_max": d.grid.v_max},
        "method": d.method,
        "units": {"input": d.input_unit, "output": d.output_unit},
        "drift_monitor": drift_monitor,
    }


def use_clock(d: Diagnosis) -> list[dict[str, Any]]:
    """Each session drift scored beside its twin on a clock of use (:mod:`identify.diagnosis.use_clock`):
    ``[{effect, clock, z}]``, ``z`` how many standard errors more the twin improves the held-out error than
    the drift, judged by a delete-one-block jackknife (positive: the change follows use better than session
    time; null with fewer than three held-out blocks)."""
    ev = d.evidence
    if ev is None:
        return []
    out = []
    for name, clock in zip(ev.twins, ev.twin_clocks):
        z = ev.use_z(name)
        out.append({"effect": name, "clock": clock, "z": float(z) if z is not None and np.isfinite(z) else None})
    return out


def look_alikes(names) -> dict[str, list[str]]:
    """For each effect of ``names`` that has them, the mechanisms outside the library its family also reaches
    (:attr:`identify.effects.Effect.look_alikes`), ``{effect: [description, ...]}``."""
    from identify.effects import EFFECTS

    return {n: list(EFFECTS[n].look_alikes) for n in names if n in EFFECTS and EFFECTS[n].look_alikes}


def _named(d: Diagnosis) -> tuple[str, ...]:
    """The effects the verdict puts forward: those explained, or the rivals of an ambiguity."""
    v = d.verdict
    if v.status == "explained":
        return tuple(v.effects) or ((v.effect,) if v.effect else ())
    return tuple(v.rivals or v.contenders) if v.status == "ambiguous" else ()


def _rmse_with(d: Diagnosis, leading) -> float | None:
    """The held-out RMSE with the effect(s) the verdict rests on."""
    v = d.verdict
    if v.status == "explained" and len(v.effects) > 1 and v.shrink is not None:
        return d.baseline_rmse_um * (1.0 - v.shrink)
    return leading.rmse_um if leading and v.status in ("explained", "ambiguous") else None


def identify_command(d: Diagnosis, fit: list[str]) -> str | None:
    """The ``rig identify`` command that stores the kept model (one identification run only)."""
    if d.kept is None or len(fit) != 1:
        return None
    path, _, curves = fit[0].partition(":")
    parts = ["rig identify", path, "--method", d.method]
    if curves in ("even", "odd"):
        parts += ["--curves", curves]
    effects = [e for e in d.kept.effects if e != "resolution"]
    if len(effects) < len(d.kept.effects):
        parts += ["--levels", str(d.kept.params.get("resolution", {}).get("levels", d.grid.levels))]
    return " ".join(parts + (["--with", ",".join(effects)] if effects else []))


def kept_json(d: Diagnosis, fit: list[str]) -> dict[str, Any] | None:
    """``verdict.model``: the model ``rig identify --with`` stores for the named effect(s), held out."""
    k = d.kept
    if k is None:
        return None
    return {"effects": list(k.effects), "rmse_um": k.rmse_um, "shrink": k.shrink,
            "base_rmse_um": d.fit_only_rmse_um, "params": k.params, "seconds": k.seconds, "error": k.error,
            "command": identify_command(d, fit)}


def _fmt(x: float | None, spec: str = ".4g") -> str:
    return "-" if x is None or not np.isfinite(x) else format(x, spec)


#: Bins shown per quantity in the readable report (the most extreme of those that stand out).
SHOWN_BINS = 2


def _stand_out(w: Binning, unit: str = "um") -> str | None:
    out = [b for b in w.bins if b.significant]
    if not out:
        return None
    top = sorted(out, key=lambda b: -max(abs(b.mean_um), b.rms_um))[:SHOWN_BINS]
    text = "; ".join(
        f"{b.label or f'{b.lo:.3g}..{b.hi:.3g} {w.unit}'.rstrip()}: mean {b.mean_um:+.2g}, rms {b.rms_um:.2g} {unit} (n={b.n})"
        for b in top
    )
    return f"{len(out)} of {len(w.bins)} bins stand out, most: {text}"


def to_text(d: Diagnosis, fit: list[str], check: list[str], warnings: list[str],
            drift_monitor: dict[str, Any] | None = None) -> str:
    """The readable report: how far, where, which, the verdict, and the drift monitor when there is one."""
    u, vu = d.output_unit, d.input_unit
    lines = [
        f"Gap diagnosis: equation (22) fitted on {', '.join(fit)} ({d.method}, L={d.grid.levels} on "
        f"[{d.grid.v_min:g}, {d.grid.v_max:g}] {vu}), judged on {', '.join(check)} "
        f"({d.points.residual.size} held-out points)",
        "",
    ]
    for w in list(warnings) + list(d.warnings):
        lines.append(f"warning: {w}")
    if warnings or d.warnings:
        lines.append("")
    v = d.verdict
    headline = {
        "explained": f"EXPLAINED by {' + '.join(v.effects) if v.effects else v.effect}",
        "ambiguous": f"AMBIGUOUS between {', '.join(v.rivals or v.contenders)}",
        "unexplained": "UNEXPLAINED" + (f" (best partial: {v.contenders[0]})" if v.contenders else ""),
        "no_gap": "NO GAP",
        "cannot_tell": "CANNOT TELL",
    }[v.status]
    lines.append(f"Verdict: {headline} -- {v.reason}.")
    for name, alikes in look_alikes(_named(d)).items():
        lines.append(f"  Looks like {name} too, and not in the library: {'; '.join(alikes)}. These runs cannot "
                     f"tell them apart; what is known of the rig can.")
    noise = d.noise
    if d.floor_kind == "bound":
        floor = (f"noise floor not measured; at most {_fmt(d.noise_floor_um)} {u} (an upper bound from the base "
                 f"fit's residual, plus identification noise carried by the fit)")
    elif noise:
        floor = (f"noise floor {_fmt(d.noise_floor_um)} {u} (measurement noise {_fmt(d.measurement_noise_um)} {u} "
                 f"from {noise.source}, plus identification noise carried by the fit)")
    else:
        floor = "noise floor unknown"
    lines.append(f"How far: held-out RMSE {_fmt(d.baseline_rmse_um)} {u}; {floor}.")
    if d.recalibrated:
        lines.append(
            f"  (as identified the model misses by {_fmt(d.fit_only_rmse_um)} {u}; {d.recalibrated} direction(s) of "
            f"the fit into which the identification design amplifies noise (x{d.amplification[0]:.1f}; on the "
            f"damped oscillation chiefly the thermal term, identified through one point) are re-estimated on "
            f"held-out check blocks first)"
        )
    chosen = d.chosen
    if v.status == "explained" and len(v.steps) > 1:
        for step in v.steps:
            sh = step["share_closed"]
            lines.append(f"  step {step['effect']}: shrink {100 * step['shrink']:.0f} % of what was left"
                         + (f", {100 * sh:.0f} % of the excess" if sh is not None else "") + f" (z {step['z']:.1f}).")
        lines.append(f"  with {' + '.join(v.effects)}: {_fmt(_rmse_with(d, None))} {u}, shrink {100 * v.shrink:.0f} %.")
    elif chosen is not None:
        c = d.score(chosen)
        share = f", {100 * c.share_closed:.0f} % of the excess over the noise floor" if c.share_closed is not None else ""
        lines.append(f"  with {chosen}: {_fmt(c.rmse_um)} {u}, shrink {100 * c.shrink:.0f} % "
                     f"[{100 * c.ci[0]:.0f}, {100 * c.ci[1]:.0f}]{share}.")
    k = d.kept
    if k is not None:
        what = " + ".join(k.effects)
        if k.error is not None:
            lines.append(f"Keep it: no model with {what} can be identified from the identification run(s) -- {k.error}.")
        else:
            cmd = identify_command(d, fit)
            how = f"`{cmd}` stores" if cmd else "rig identify --with stores"
            lines.append(f"Keep it: {how} the model with {what}, fitted on the identification run(s) alone: "
                         f"held-out RMSE {_fmt(k.rmse_um)} {u} against {_fmt(d.fit_only_rmse_um)} {u} for the base "
                         f"model as identified, shrink {100 * k.shrink:.0f} %.")
    lines.append("")
    lines.append("Where (residual = model - measured; bins that stand out beyond the noise):")
    any_out = False
    for w in d.where:
        out = _stand_out(w, u)
        if out:
            any_out = True
            lines.append(f"  by {w.by}: {out}")
    if not any_out:
        lines.append("  no bin stands out")
    lines.append("")
    lines.append("Which (held-out, every candidate fitted jointly with the base model):")
    rows = []
    for c in d.candidates:
        rows.append([c.effect, c.rmse_um, f"{100 * c.shrink:+.0f} %", f"[{100 * c.ci[0]:+.0f}, {100 * c.ci[1]:+.0f}]",
                     round(c.z, 1), "-" if c.share_closed is None else f"{100 * c.share_closed:.0f} %",
                     "yes" if c.visible else "no"])
    lines.append(format_table(["effect", f"rmse ({u})", "shrink", "95% interval", "z", "of excess", "visible"], rows))
    for c in d.candidates:
        if c.note:
            lines.append(f"  {c.effect}: {c.note}")
    for effect, reason in d.not_assessed:
        lines.append(f"  {effect}: not assessed -- {reason}")
    if chosen is not None:
        lines.append("")
        lines.append(f"{chosen}: {summary(chosen)}; fitted: {_params_text(d.score(chosen).params)}")
    if drift_monitor is not None:
        lines.append("")
        lines.append(drift_text(drift_monitor, u))
    return "\n".join(lines)


def drift_text(m: dict[str, Any], unit: str) -> str:
    """One paragraph: the calibration points against the drift the diagnosis inferred."""
    head = (f"Drift monitor: {m['n']} calibration points measured {_fmt(m['measured_rms'])} {unit} rms "
            f"(range {_fmt(m['measured_range'])} {unit}) over the session")
    if m.get("drift_correction"):
        head += f", outputs already drift-corrected ({m['drift_correction']})"
    if m.get("inferred_rms") is None:
        return head + f"; {m['note']}."
    return (head + f"; baseline_drift inferred on {m['run']} {_fmt(m['inferred_rms'])} {unit} rms at those "
            f"times, correlation {_fmt(m['correlation'], '.2f')}, rms difference {_fmt(m['rms_difference'])} {unit}"
            f" -- {m['agreement']}.")


def _params_text(params: dict[str, Any], depth: int = 0) -> str:
    """A candidate's fitted ``params`` in one line: scalars, and dicts of them to two levels (a drift's runs,
    each with its rms, range and change); sequences (a spline's knots and coefficients) only in the JSON."""
    parts = []
    for k, v in params.items():
        if isinstance(v, dict):
            inner = _params_text(v, depth + 1) if depth < 2 else ""
            if inner:
                parts.append(f"{k} {{{inner}}}")
        elif isinstance(v, (list, tuple, np.ndarray)):
            continue
        elif isinstance(v, float):
            parts.append(f"{k} {v:.3g}")
        else:
            parts.append(f"{k} {v}")
    return ", ".join(parts)


def write_figures(d: Diagnosis, out_dir: Path) -> list[Path]:
    """``where.png`` (binned residuals before and after the chosen effect) and ``candidates.png`` in
    ``out_dir`` (created); returns their paths."""
    # matplotlib is imported here, not when the rig command starts
    from ..plots.diagnosis import candidates_figure, where_figure
    from ..plots.style import save_figure

    out_dir.mkdir(parents=True, exist_ok=True)
    return [save_figure(where_figure(d), out_dir / "where.png"),
            save_figure(candidates_figure(d), out_dir / "candidates.png")]
