"""rig report: PNG figures and a Markdown summary of a session, its model and a validation run."""

import re

import numpy as np
import pytest

from identify import Excitation
from rig.plots.style import DPI
from rig.model_scoring import score_model
from rig.session_input import choose_model, open_run
from rig.session_report import ScoredRun, build_report
from sessions import Quantities

from .cli import assert_one_line_error, rig_here
from .conftest import digest, known_model
from .sessionkit import write_run
from .test_plots import png_size

OWN = ["time.png", "loop.png", "density.png", "residual.png"]
VALIDATION = ["validation-time.png", "validation-loop.png", "validation-residual.png"]


@pytest.fixture
def fitted(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    s, v = tmp_path / "s.h5", tmp_path / "v.h5"
    write_run(s, truth, Excitation.damped(truth.grid), noise=0.01, seed=1, operator="ada")
    write_run(v, truth, Excitation.random(truth.grid, 50, seed=4), noise=0.02, seed=2)
    assert rig_here("identify", s, "--method", "cs_order_nn").code == 0
    return s, v


def built(session, validation=None):
    data = open_run(session, allow_partial=False)
    record = choose_model(data.session, None)
    checked = None
    if validation is not None:
        v = open_run(validation, allow_partial=False)
        checked = ScoredRun(v, score_model(record, v))
    return build_report(ScoredRun(data, score_model(record, data, fitted_on=True)), record, checked)


@pytest.mark.slow
def test_report_writes_the_figures_and_a_summary_linking_them(fitted, tmp_path):
    s, v = fitted
    before = digest(s), digest(v)
    out = tmp_path / "rep"
    run = rig_here("report", s, "--validate", v, "--out", out, "--json")
    assert run.code == 0, run.err
    result = run.json()
    assert result["model"] == "cs_order_nn" and result["summary"] == str(out / "report.md")
    assert [p.rsplit("/", 1)[-1] for p in result["figures"]] == OWN + VALIDATION
    figures = built(s, v).figures
    for name in OWN + VALIDATION:
        path = out / name
        w, h = figures[name].get_size_inches() * DPI
        assert png_size(path) == (round(w), round(h)), name
        assert path.stat().st_size > 20_000, name
    summary = (out / "report.md").read_text()
    assert re.findall(r"\]\(([\w.-]+\.png)\)", summary) == OWN + VALIDATION  # every figure linked, in order
    assert "# Session report: s.h5" in summary and "| operator | ada |" in summary
    assert "## Model `cs_order_nn`" in summary and "## Validation on v.h5" in summary
    checked = rig_here("validate", s, "--on", v, "--json").json()
    assert result["validation"]["rmse"] == checked["rmse"] and result["validation"]["nrmse"] == checked["nrmse"]
    assert f"| RMSE | {checked['rmse']:.4g} µm |" in summary
    assert (digest(s), digest(v)) == before  # the sessions are only read
    # again, into the default directory beside the session: replaces its own files only
    (tmp_path / "s-report").mkdir()
    (tmp_path / "s-report" / "notes.txt").write_text("mine")
    run = rig_here("report", s)
    assert run.code == 0, run.err
    assert sorted(p.name for p in (tmp_path / "s-report").iterdir()) == sorted(OWN + ["report.md", "notes.txt"])
    assert "Validation" not in (tmp_path / "s-report" / "report.md").read_text()


def test_figures_carry_the_session_quantities(tmp_path):
    """A session in other quantities (T in, A m^2 out): every label says so, none says V or um."""
    truth = known_model(5, v_min=-1.0, v_max=1.0, seed=3)
    q = Quantities(input_quantity="applied field", input_unit="T",
                   output_quantity="magnetic moment", output_unit="A m^2")
    s, v = tmp_path / "forc.h5", tmp_path / "val.h5"
    write_run(s, truth, Excitation.damped(truth.grid), quantities=q)
    write_run(v, truth, Excitation.random(truth.grid, 30, seed=1), quantities=q, noise=0.01)
    assert rig_here("identify", s, "--name", "forc").code == 0
    figures = built(s, v).figures
    labels = {name: [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes] for name, fig in figures.items()}
    assert labels["time.png"] == [("", "applied field (T)"), ("time (s)", "magnetic moment (A·m²)")]
    assert labels["loop.png"] == [("applied field (T)", "magnetic moment (A·m²)")]
    assert labels["density.png"] == [("alpha, up-switching input (T)", "beta, down-switching input (T)"),
                                     ("", "density ((A·m²)/T²)")]
    assert labels["residual.png"] == [("applied field (T)", "residual, model − measured (A·m²)")]
    assert labels["validation-loop.png"] == labels["loop.png"]
    assert labels["validation-residual.png"] == labels["residual.png"]
    text = " ".join(f"{x} {y}" for pairs in labels.values() for x, y in pairs)
    assert "(V)" not in text and "µm" not in text
    titles = [fig.axes[0].get_title() for fig in figures.values()]
    assert all(titles) and "forc.h5, model forc" in titles[0] and "val.h5, model forc" in titles[-1]
    # the residual figure holds the measured points, by branch
    heating, cooling = figures["residual.png"].axes[0].get_lines()[-2:]
    assert heating.get_xdata().size + cooling.get_xdata().size == truth.grid.n_cells + 2  # N + thermal point
    assert np.all(np.isfinite(heating.get_ydata()))


@pytest.mark.slow
def test_every_text_fits_in_its_figure(tmp_path):
    """Long names (session, model) are not clipped: titles, labels and notes lie inside the figure."""
    truth = known_model(6, v_min=0.0, v_max=3.0)
    s = tmp_path / "bench-2026-03-14-afternoon-run-after-recalibration.h5"
    write_run(s, truth, Excitation.damped(truth.grid), noise=0.01)
    assert rig_here("identify", s, "--method", "cs_order_nn", "-M", 20, "--seed", 11).code == 0
    for name, fig in built(s, s).figures.items():
        fig.canvas.draw()
        box = fig.bbox
        for ax in fig.axes:
            for text in [ax.title, ax.xaxis.label, ax.yaxis.label, *ax.texts]:
                if text.get_text():
                    b = text.get_window_extent()
                    assert box.x0 <= b.x0 and b.x1 <= box.x1 and box.y0 <= b.y0 and b.y1 <= box.y1, \
                        (name, text.get_text())


def test_report_bad_cases_write_nothing(fitted, tmp_path):
    s, v = fitted
    truth = known_model(6, v_min=0.0, v_max=3.0)
    bare, wide, part = tmp_path / "bare.h5", tmp_path / "wide.h5", tmp_path / "part.h5"
    write_run(bare, truth, Excitation.damped(truth.grid))
    write_run(wide, truth, Excitation.random(known_model(6, 0.0, 4.0).grid, 20, seed=1))
    write_run(part, truth, Excitation.damped(truth.grid), n=10, status="aborted")
    (tmp_path / "file").write_text("x")
    files = [s, v, bare, wide, part, tmp_path / "file"]
    before = [digest(p) for p in files]
    out = tmp_path / "out"
    assert_one_line_error(rig_here("report", bare, "--out", out), "holds no model")
    assert_one_line_error(rig_here("report", s, "--validate", wide, "--out", out), "covers only [0, 3] V")
    assert_one_line_error(rig_here("report", part, "--out", out), "partial", "--partial")
    assert_one_line_error(rig_here("report", s, "--model", "other", "--out", out), "no model named 'other'")
    assert_one_line_error(rig_here("report", s, "--out", tmp_path / "file"), "is a file")
    assert_one_line_error(rig_here("report", v.with_name("none.h5")), "no such file")
    assert [digest(p) for p in files] == before
    assert not out.exists() and not (tmp_path / "bare-report").exists()
