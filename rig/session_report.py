"""``rig report``: the figures of a session and its model, and a Markdown summary linking them.

:func:`build_report` is pure (recorded runs and a stored model in, figures
and text out); :func:`write_report` writes them.  Figure files:

* ``time.png`` -- input and output against time, with the model's prediction;
* ``loop.png`` -- the hysteresis loop, measured against model;
* ``density.png`` -- the identified density on the Preisach triangle;
* ``residual.png`` -- residual against input, by branch (heating/cooling);
* ``validation-time.png``, ``validation-loop.png``, ``validation-residual.png``
  -- the same for a validation run, when one is given;

and ``report.md``, the summary.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from identify.branch import branches
from identify.validation import ValidationReport, model_path
from sessions import ModelRecord, Session
from sessions.recording import Recording

from .output import nrmse_text
from .plots import density_figure, loop_figure, residual_figure, save_figure, time_figure
from .plots.style import DEFLECTION, HEATER_VOLTAGE, Quantity, display_unit, ratio_unit
from .model_scoring import score_model

#: Name of the Markdown summary in the report directory.
SUMMARY = "report.md"
#: At most this many points on the model's path in a loop figure (8 per ramp for runs up to 2500 points).
PATH_POINTS = 20_000


def quantities_of(data: Recording) -> tuple[Quantity, Quantity]:
    """The input and output quantities of a run: the session's own, the rig's for a CSV trace."""
    if data.session is None:
        return HEATER_VOLTAGE, DEFLECTION
    q = data.session.quantities
    return Quantity(q.input_quantity, q.input_unit), Quantity(q.output_quantity, q.output_unit)


@dataclass(frozen=True, eq=False)
class ScoredRun:
    """A recorded run with a model's prediction of it."""

    data: Recording
    score: ValidationReport


@dataclass(eq=False)
class Report:
    """Figures by file name, in reading order, and the Markdown summary."""

    figures: dict[str, Figure] = field(default_factory=dict)
    markdown: str = ""


def effect_contributions(record: ModelRecord, data: Recording) -> dict[str, np.ndarray]:
    """Each of the model's effects' contribution to the reading over the run ``(n,)`` (empty without effects);
    a drift of a run the model was not fitted on contributes nothing here."""
    if not record.model.effects:
        return {}
    from identify.effects.compose import contributions

    from .session_input import run_of

    return contributions(record.model, run_of(data))


def run_figures(run: ScoredRun, record: ModelRecord, prefix: str, what: str) -> dict[str, Figure]:
    """Time, loop and residual figures of one run (file names start with ``prefix``), and the effects'
    contributions beside the residual when the model has effects."""
    d, s = run.data, run.score
    vq, yq = quantities_of(d)
    name = f"{d.path.name}, model {record.name}"
    steps = max(1, min(8, PATH_POINTS // max(1, d.inputs.size)))
    extra = {}
    parts = effect_contributions(record, d)
    if parts:
        from .plots.effects import effects_figure

        extra[f"{prefix}effects.png"] = effects_figure(
            d.t_s if d.t_s is not None else np.arange(d.inputs.size, dtype=float), parts, s.rows, s.residual, yq,
            title=f"Effects of the model and the residual, {what.lower()}\n{name}")
    return {**extra, **{
        f"{prefix}time.png": time_figure(d.t_s, d.inputs, d.outputs, vq, yq, prediction=s.prediction,
                                         title=f"{what}\n{name}"),
        f"{prefix}loop.png": loop_figure(d.inputs, d.outputs, vq, yq, model_path=model_path(record.model, d.inputs, steps),
                                         title=f"Hysteresis loop, {what.lower()}\n{name}"),
        f"{prefix}residual.png": residual_figure(
            d.inputs[s.rows], s.residual, branches(d.inputs)[s.rows], vq, yq,
            title=f"Residual, {what.lower()}: RMSE {s.rmse:.3g} {display_unit(yq.unit)}, "
                  f"nRMSE {nrmse_text(s.nrmse)}\n{name}"),
    }}


def score_runs(record: ModelRecord, data: Recording, validation: Recording | None = None
               ) -> tuple[ScoredRun, ScoredRun | None]:
    """The model's run ``data`` (scored as the run it was fitted on) and, if given, a validation run
    (scored on the model's grid); one-line errors from :func:`rig.model_scoring.score_model`."""
    fitted = ScoredRun(data, score_model(record, data, fitted_on=True))
    checked = None if validation is None else ScoredRun(validation, score_model(record, validation))
    return fitted, checked


def build_report(fitted: ScoredRun, record: ModelRecord, validation: ScoredRun | None = None) -> Report:
    """Every figure and the summary for the session of ``fitted`` and its model ``record``."""
    vq, yq = quantities_of(fitted.data)
    report = Report()
    own = run_figures(fitted, record, "", "Identification run")
    report.figures = {
        "time.png": own["time.png"],
        "loop.png": own["loop.png"],
        "density.png": density_figure(record.model, vq, yq,
                                      title=f"Identified density\n{fitted.data.path.name}, model {record.name} ({record.method})"),
        "residual.png": own["residual.png"],
        **({"effects.png": own["effects.png"]} if "effects.png" in own else {}),
    }
    if validation is not None:
        report.figures.update(run_figures(validation, record, "validation-", "Validation run"))
    report.markdown = summary_markdown(fitted, record, validation)
    return report


# ------------------------------------------------------------------ summary
def _fmt(x: float) -> str:
    return f"{x:.4g}"


def _session_rows(session: Session | None, data: Recording) -> list[tuple[str, str]]:
    if session is None:
        return [("file", f"`{data.path.name}` (CSV trace)"), ("points", str(data.inputs.size))]
    e = session.excitation
    grid = f", L = {e.levels} on [{e.v_min:g}, {e.v_max:g}] {display_unit(session.quantities.input_unit)}" \
        if e.levels is not None else ""
    rows = [
        ("file", f"`{session.path.name}`"),
        ("started", session.started_at),
        ("ended", session.ended_at or "-"),
        ("status", f"{session.status.value}: {session.n_samples} of {e.n_points} points applied, "
                   f"{int(session.measured.sum())} measured"),
        ("excitation", f"{e.kind}{grid}{', with the thermal point' if e.thermal_term else ''}"),
    ]
    if session.operator:
        rows.append(("operator", session.operator))
    if session.notes:
        rows.append(("notes", " ".join(session.notes.split())))
    return rows


def _table(rows: list[tuple[str, str]]) -> list[str]:
    out = ["| | |", "|---|---|"]
    out += [f"| {k} | {v.replace('|', '/')} |" for k, v in rows]
    return out


def _score_rows(score: ValidationReport, unit: str) -> list[tuple[str, str]]:
    return [
        ("points predicted / compared", f"{score.n_points} / {score.n_measured}"),
        ("RMSE", f"{_fmt(score.rmse)} {unit}"),
        ("normalised RMSE", f"{nrmse_text(score.nrmse)} ({_fmt(score.output_range)} {unit})"),
        ("maximum error", f"{_fmt(score.max_abs)} {unit}"),
    ]


def _figures(names: list[str], captions: dict[str, str]) -> list[str]:
    out = []
    for n in names:
        out += ["", f"### {captions[n]}", "", f"![{captions[n]}]({n})"]
    return out


CAPTIONS = {
    "time.png": "Input and output against time",
    "loop.png": "Hysteresis loop, measured and model",
    "density.png": "Identified density on the Preisach triangle",
    "residual.png": "Residual against input, by branch",
    "effects.png": "The model's effects over the run, beside the residual",
}


def summary_markdown(fitted: ScoredRun, record: ModelRecord, validation: ScoredRun | None) -> str:
    """The Markdown summary: the session, the model and its errors, the figures."""
    session = fitted.data.session
    vq, yq = quantities_of(fitted.data)
    ou, iu = display_unit(yq.unit), display_unit(vq.unit)
    m, g, metrics = record.model, record.model.grid, record.metrics
    title = session.path.name if session is not None else fitted.data.path.name
    lines = [f"# Session report: {title}", ""]
    lines += _table(_session_rows(session, fitted.data))
    lines += ["", f"## Model `{record.name}`", ""]
    used = f"{metrics.get('n_measured', record.rows.size)} of {metrics.get('n_points', '?')} points"
    if record.seed is not None:
        used += f" (chosen at random, seed {record.seed})"
    lines += _table([
        ("method", record.method),
        ("grid", f"L = {g.levels} on [{g.v_min:g}, {g.v_max:g}] {iu}"),
        ("thermal term", "yes" if record.thermal_term else "no"),
        *([("effects", ", ".join(e.name for e in m.effects))] if m.effects else []),
        ("mu0", f"{_fmt(m.mu0)} {ou}"),
        ("c_d", f"{_fmt(m.c_d)} {ratio_unit(yq.unit, vq.unit)}"),
        ("fitted on", used),
        ("fit RMSE (points used)", f"{_fmt(metrics.get('rmse', float('nan')))} {ou}, "
                                   f"nRMSE {nrmse_text(metrics.get('nrmse', float('nan')))}"),
        ("fit time", f"{_fmt(metrics.get('seconds', float('nan')))} s"),
        ("stored", f"{record.created_at} by vo2rig {record.software_version}"),
    ])
    lines += ["", "Prediction of every measured point of this run (memory from negative saturation):", ""]
    lines += _table(_score_rows(fitted.score, ou))
    lines += ["", "## Figures"]
    own = ["time.png", "loop.png", "density.png", "residual.png"] + (["effects.png"] if m.effects else [])
    lines += _figures(own, CAPTIONS)
    if validation is not None:
        v_session = validation.data.session
        lines += ["", f"## Validation on {validation.data.path.name}", ""]
        lines += _table(_session_rows(v_session, validation.data) + _score_rows(validation.score, ou))
        names = ["validation-time.png", "validation-loop.png", "validation-residual.png"]
        names += ["validation-effects.png"] if m.effects else []
        lines += _figures(names, {f"validation-{k}": v for k, v in CAPTIONS.items()})
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ writing
def write_report(report: Report, out_dir: str | os.PathLike) -> list[Path]:
    """Write the figures and the summary into ``out_dir`` (created if needed); returns the paths.

    Each file is written beside its final name and renamed over it, so an
    interrupted report never leaves a half-written figure; other files in
    ``out_dir`` are left alone.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, fig in report.figures.items():
        written.append(_replace(out / name, lambda tmp, fig=fig: save_figure(fig, tmp)))
    written.append(_replace(out / SUMMARY, lambda tmp: tmp.write_text(report.markdown, encoding="utf-8")))
    return written


def _replace(path: Path, write) -> Path:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
