"""Plug-ins carry their own knowledge: a new effect and a new method, each one class and one registry line.

:class:`SetpointCube` (an effect) and :class:`DenseNNLS` (a method) are defined here, as a new module of
``identify/effects/`` or ``identify/methods/`` would define them, and joined to their registry the way one
line in it would: the tuple ``identify.effects.EFFECT_CLASSES`` or ``identify.methods.METHOD_CLASSES``
extended (by ``monkeypatch`` in this process, by :func:`install` in a ``rig`` process).  Nothing else is
touched, and they appear in ``rig identify --with`` / ``--method`` (help and acceptance), the diagnosis's
library, ``rig study``, ``rig watch``, the budget and the inverse.

This module imports nothing of ``rig`` at the top: a ``rig`` process imports it before its commands.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import identify.effects as effects_registry
import identify.methods as methods_registry
from identify import Grid, PreisachModel
from identify.effects import OUTPUT, Effect, EffectNotApplicable
from identify.effects.base import finite, needs_heater, require_params, single_columns
from identify.methods.least_squares import LeastSquares
from identify.runs import Run
from identify.model_json import model_from_dict, model_to_dict

REPO = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------- the plug-ins, as their own modules would be
class SetpointCube(Effect):
    """The deflection gains ``a v^3`` (um, ``a`` in um/V^3): a function of the set-point alone."""

    name = "setpoint_cube"
    summary = "the deflection gains a cubic of the heater voltage (a test plug-in)"
    stage = OUTPUT
    must_record = (needs_heater,)
    inversion = "static"
    static_degree = 3

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("um_per_V3",), self.name)
        return {"um_per_V3": finite(params, "um_per_V3", self.name)}

    def columns(self, ctx, setting):
        return single_columns(ctx.runs, [r.inputs[:, None] ** 3 for r in ctx.runs], ("um_per_V3",))

    def with_fit(self, ctx, setting, coef, cols) -> "SetpointCube":
        return SetpointCube({"um_per_V3": float(coef[0])})

    def contribution(self, run, u=None, phase=None, start=None) -> np.ndarray:
        return self.params["um_per_V3"] * run.inputs ** 3


class DenseNNLS(LeastSquares):
    """Lawson-Hanson on the dense measured rows of ``S``: ``ls``'s reference path as a method of its own."""

    name = "nnls_dense"
    label = "Dense NNLS (a test plug-in)"
    refits_live = True

    def __init__(self, solver: str = "dense") -> None:
        super().__init__("dense")

    @classmethod
    def cost(cls, parameters: int, points: int, measured: int, square: bool) -> tuple[float, float]:
        return 1e-3 * parameters * measured, 1e3 * parameters * measured  # recognisable, not measured


def install() -> None:
    """The two registry lines, in a process of its own (a ``rig`` command's)."""
    effects_registry.EFFECT_CLASSES = (*effects_registry.EFFECT_CLASSES, SetpointCube)
    methods_registry.METHOD_CLASSES = (*methods_registry.METHOD_CLASSES, DenseNNLS)


@pytest.fixture
def plugged(monkeypatch):
    """The two registry lines, in this process, for one test."""
    monkeypatch.setattr(effects_registry, "EFFECT_CLASSES", (*effects_registry.EFFECT_CLASSES, SetpointCube))
    monkeypatch.setattr(methods_registry, "METHOD_CLASSES", (*methods_registry.METHOD_CLASSES, DenseNNLS))


#: ``rig ARGS`` with the plug-ins installed first.
BOOT = ("import sys\nimport tests.test_plugins as plugins\nplugins.install()\nfrom rig.cli import main\n"
        "sys.argv = ['rig', *sys.argv[1:]]\nmain()\n")


def rig_plugged(*args, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "RIG_DEBUG": "", "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", BOOT, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=300)


def squeezed(text: str) -> str:
    """``text`` without whitespace (a help text's wrapping)."""
    return "".join(text.split())


def a_run(truth: PreisachModel, name: str = "fit", n: int = 160, seed: int = 1) -> Run:
    rng = np.random.default_rng(seed)
    v = np.clip(3.0 + 2.9 * np.sin(np.linspace(0.0, 9.0, n)) * np.exp(-np.linspace(0.0, 1.2, n))
                + rng.normal(0.0, 0.3, n), 0.0, 6.0)
    t = np.cumsum(np.full(n, 5.0))
    run = Run(name, v, np.zeros(n), t, np.full(n, 5.0))
    return dataclasses.replace(run, outputs=truth.predict_run(run))


def truth_with_cube() -> PreisachModel:
    g = Grid(6, 0.0, 6.0)
    density = np.random.default_rng(0).uniform(0.0, 1.0, g.n_cells) * 10.0 / g.n_cells
    return PreisachModel(g, density, 1.0, -0.5, effects=(SetpointCube({"um_per_V3": 0.02}),))


# ---------------------------------------------------------------- the effect
def test_without_the_registry_line_neither_is_known():
    assert "setpoint_cube" not in effects_registry.EFFECTS and "nnls_dense" not in methods_registry.METHODS


def test_the_effect_is_named_fitted_stored_and_diagnosed(plugged):
    from identify.diagnosis import NAMES, library
    from identify.fit import fit_run

    assert "setpoint_cube" in effects_registry.spellings().split(", ")
    assert "setpoint_cube" in NAMES and [e.name for e in library(["setpoint_cube"])] == ["setpoint_cube"]
    truth = truth_with_cube()
    run = a_run(truth)
    report = fit_run(truth.grid, run, "ls", effects_registry.parse_effects("setpoint_cube"))
    assert [e.name for e in report.model.effects] == ["setpoint_cube"]
    stored = model_to_dict(report.model)
    assert stored["effects"][0]["name"] == "setpoint_cube" and set(stored["effects"][0]) == {"name", "params"}
    back = model_from_dict(json.loads(json.dumps(stored)))
    np.testing.assert_allclose(back.predict_run(run), report.model.predict_run(run), rtol=0, atol=1e-12)
    # what a run must record: a heater voltage
    other = dataclasses.replace(run, input_unit="T")
    with pytest.raises(EffectNotApplicable, match="heater"):
        report.model.predict_run(other)


def test_the_effect_is_inverted_as_it_says(plugged):
    from identify.inverse import invert

    model = truth_with_cube()
    n = 60
    targets = np.clip(6.0 * np.sin(np.linspace(0.0, 10.0, n)) * np.exp(-np.linspace(0.0, 1.0, n)), -4.0, 6.0)
    result = invert(model, targets)
    forward = model.predict_run(Run("target", result.voltages, np.zeros(n), np.zeros(n), np.full(n, np.nan)))
    np.testing.assert_allclose(forward, result.predicted, rtol=0, atol=1e-9)
    assert result.reachable.mean() > 0.5
    np.testing.assert_allclose(forward[result.reachable], targets[result.reachable], rtol=0, atol=1e-9)


# ---------------------------------------------------------------- the method
def test_the_method_is_fitted_budgeted_studied_and_refitted_live(plugged):
    from identify.fit import fit_run
    from identify.study import StudySetup, summarise
    from identify.study.paper import label
    from rig.budget.identification import estimate_fit, n_parameters
    from rig.plots.study import marker
    from rig.study_runner import run_study

    assert "nnls_dense" in methods_registry.DAMPED_METHODS and "nnls_dense" in methods_registry.LIVE_METHODS
    truth = dataclasses.replace(truth_with_cube(), effects=())
    report = fit_run(truth.grid, a_run(truth), "nnls_dense")
    assert report.method == "nnls_dense" and report.rmse < 1e-6
    # the budget: its own cost model
    cost = estimate_fit("nnls_dense", 30, 467, 300)
    assert cost.memory_bytes > 1e3 * n_parameters(30) * 300
    # the study: accepted, fitted, labelled, marked
    setup = StudySetup(profile="gaussian", levels=4, measurements=10, runs=2, methods=("ls", "nnls_dense"),
                       validation_points=20)
    summary = summarise(setup, run_study(setup, workers=1, progress=False))
    assert set(summary.main.per_run) == {"ls", "nnls_dense"}
    assert label("nnls_dense") == DenseNNLS.label
    assert marker("nnls_dense") not in {marker(m) for m in methods_registry.METHODS if m != "nnls_dense"}


# ---------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def session(tmp_path_factory) -> Path:
    from .cli import rig_here

    path = tmp_path_factory.mktemp("plugins") / "s.h5"
    assert rig_here("acquire", "--levels", "6", "--out", path, "--no-progress").code == 0
    return path


def test_the_command_line_offers_and_accepts_them(session, tmp_path):
    from .cli import assert_one_line_error, rig_here

    helps = {cmd: rig_plugged(cmd, "--help", cwd=tmp_path) for cmd in ("identify", "study", "watch", "diagnose")}
    assert all(h.returncode == 0 for h in helps.values()), {c: h.stderr for c, h in helps.items()}
    identify_help = squeezed(helps["identify"].stdout)
    assert "nnls_dense" in identify_help and "setpoint_cube" in identify_help
    assert "nnls_dense" in squeezed(helps["study"].stdout) and "nnls_dense" in squeezed(helps["watch"].stdout)
    assert "setpoint_cube" in squeezed(helps["diagnose"].stdout)

    done = rig_plugged("identify", session, "--method", "nnls_dense", "--with", "setpoint_cube", "--no-store",
                       "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    fit = json.loads(done.stdout)
    assert fit["method"] == "nnls_dense" and [e["name"] for e in fit["effects"]] == ["setpoint_cube"]

    study = rig_plugged("study", "-L", 3, "-M", 5, "--runs", 1, "--method", "nnls_dense", "--workers", 1, "--json",
                        cwd=tmp_path)
    assert study.returncode == 0, study.stderr
    assert list(json.loads(study.stdout)["methods"]) == ["nnls_dense"]

    # without the registry lines, the same command line is refused
    assert_one_line_error(rig_here("identify", session, "--method", "nnls_dense", "--no-store"), "nnls_dense")
