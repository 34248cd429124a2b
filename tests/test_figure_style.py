"""One convention in every figure and summary (issue 17, finding 8).

nRMSE was a fraction in the tables and JSON but a percent in ``report.md``
and the figures, and the study's figures had their own style ("um", panels
without y labels).  Every figure of every command now shares
:mod:`rig.plots.style` -- labelled axes, units as people write them (µm), the
shared font sizes -- and nRMSE is a fraction of the output range everywhere.
"""

from __future__ import annotations

import re

import pytest

from identify import Excitation
from identify.study import StudySetup, run_trials, summarise
from rig.plots.study import study_figures
from rig.plots.style import LABEL_SIZE, TICK_SIZE

from .cli import rig_here
from .conftest import known_model
from .sessionkit import write_run
from .test_report import built

#: "um" written as a word: the ASCII spelling that figures must show as µm.
ASCII_MICRO = re.compile(r"\bum\b")


def texts_of(fig):
    """Every string a figure shows: titles, axis labels, tick labels, legend entries, other text."""
    out = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
    return [t for t in out if t]


def assert_house_style(name, fig):
    for ax in fig.axes:
        if not ax.get_visible() or not ax.has_data() or ax.get_label() == "<colorbar>":
            continue
        # stacked panels that share their x axis label it once, on the panel below
        shared = [a for a in ax.get_shared_x_axes().get_siblings(ax) if a is not ax and a.get_xlabel()]
        assert ax.get_xlabel() or shared, f"{name}: a panel without an x label ({ax.get_title()!r})"
        assert ax.get_ylabel(), f"{name}: a panel without a y label ({ax.get_title()!r})"
        assert ax.yaxis.label.get_fontsize() == LABEL_SIZE, name
        assert not ax.get_xlabel() or ax.xaxis.label.get_fontsize() == LABEL_SIZE, name
        ticks = [t for t in ax.get_yticklabels() if t.get_text()]
        assert all(t.get_fontsize() == TICK_SIZE for t in ticks), name
    ascii_units = [t for t in texts_of(fig) if ASCII_MICRO.search(t)]
    assert not ascii_units, f"{name}: {ascii_units}"


def test_the_study_figures_share_the_house_style():
    setup = StudySetup(levels=8, measurements=20, runs=2, methods=("ls", "cs_nodct"), sweep_measurements=(15, 20),
                       sweep_noise=(0.0, 10.0), validation_points=50)
    summary = summarise(setup, run_trials(setup, setup.trials()))
    figures = study_figures(summary)
    assert sorted(figures) == ["errors.png", "fig3_dct.png", "fig4_measurements.png", "fig5a_noise.png"]
    for name, fig in figures.items():
        assert_house_style(name, fig)
    density = figures["fig4_measurements.png"].axes[0]
    assert density.get_ylabel() == "density RMSE (µm)"
    model = figures["fig4_measurements.png"].axes[1]
    assert "fraction of the output range" in model.get_ylabel()


@pytest.fixture
def report(tmp_path):
    truth = known_model(6, v_min=0.0, v_max=3.0)
    s, v = tmp_path / "s.h5", tmp_path / "v.h5"
    write_run(s, truth, Excitation.damped(truth.grid), noise=0.01, seed=1)
    write_run(v, truth, Excitation.random(truth.grid, 50, seed=4), noise=0.02, seed=2)
    assert rig_here("identify", s, "--method", "ls").code == 0
    return s, v, built(s, v)


def test_the_report_figures_share_the_house_style(report):
    _, _, rep = report
    for name, fig in rep.figures.items():
        assert_house_style(name, fig)


def test_nrmse_is_a_fraction_in_tables_json_summary_and_figures(report):
    s, v, rep = report
    checked = rig_here("validate", s, "--on", v, "--json").json()
    fraction = f"{checked['nrmse']:.3g} of the output range"
    assert fraction in rep.markdown
    assert fraction in " ".join(texts_of(rep.figures["validation-residual.png"]))
    table = rig_here("validate", s, "--on", v).out
    assert f"{checked['nrmse']:.4g}" in table  # the same number, as a fraction, in the table
    # nowhere a percent of the range
    assert not re.search(r"%\s*(of|\()", rep.markdown)
    for fig in rep.figures.values():
        assert not any("%" in t for t in texts_of(fig))


@pytest.mark.slow
def test_the_diagnosis_figures_share_the_house_style(tmp_path):
    from rig.diagnosis.demo import diagnose_simulated
    from rig.plots.diagnosis import candidates_figure, where_figure

    d = diagnose_simulated("creep", 0.1, seed=1, directory=tmp_path, levels=8, check_points=100).diagnosis
    assert_house_style("where.png", where_figure(d))
    assert_house_style("candidates.png", candidates_figure(d))
