"""The design as a value object: equality, and the operator and square solver it owns and shares."""

import gc
import importlib.util
import pickle
import weakref

import numpy as np
import pytest

import identify.regressor_design
from identify import Grid, IdentifyError, Problem, damped_oscillation, make_method
from identify.regressor_design import Design
from identify.operators import RegressorOperator
from identify.study import StudySetup, run_trials

from .conftest import known_model


def test_a_design_is_a_value():
    grid = Grid(5, 0.0, 1.0)
    v = damped_oscillation(grid, thermal_term=True)
    a = Design(grid, v, thermal_term=True)
    assert a == Design(grid, v.copy(), True) and hash(a) == hash(Design(grid, list(v), True))
    other = v.copy()
    other[3] += 1e-12
    for b in (Design(grid, other, True), Design(grid, v, False), Design(Grid(5, 0.0, 2.0), v, True),
              Design(grid, v, True, initial="positive"), Design(grid, v, True, history=[0.5])):
        assert a != b
    assert Design(grid, v, True, history=[0.5]) == Design(grid, v, True, history=np.array([0.5]))
    # a private read-only copy: changing the caller's array afterwards changes nothing
    v[:] = 0.5
    assert a == Design(grid, damped_oscillation(grid, True), True)
    assert not a.inputs.flags.writeable
    with pytest.raises(AttributeError):
        a.thermal_term = False
    with pytest.raises(IdentifyError, match="not finite"):
        Design(grid, [0.0, np.nan], True)


def test_problems_on_one_design_share_its_operator_and_square_solver():
    truth = known_model(5)
    design = Design(truth.grid, damped_oscillation(truth.grid, True), True)
    y = truth.predict(design.inputs)
    a = Problem.on(design, y, rows=np.arange(0, design.n, 2))
    b = Problem.on(design, 2 * y, rows=np.arange(1, design.n, 3))
    assert a.design is b.design is design and a.grid is truth.grid and a.inputs is design.inputs
    assert a.operator is b.operator is design.operator
    assert a.square_solver is b.square_solver is design.square_solver
    assert a.sparse_inverse is b.sparse_inverse
    # Problem.build makes a new design each time: nothing is shared through a process-wide cache
    c = Problem.build(truth.grid, design.inputs, y)
    d = Problem.build(truth.grid, design.inputs, y)
    assert c.design == d.design and c.design is not d.design
    assert c.operator is not d.operator
    # and what a design's operator computes is what a fresh one does
    w = np.random.default_rng(0).normal(size=design.n_parameters)
    fresh = RegressorOperator(truth.grid, damped_oscillation(truth.grid, True), True)
    np.testing.assert_array_equal(a.operator.matvec(w), fresh.matvec(w))


def test_refits_on_one_design_build_the_operator_and_square_solver_once(monkeypatch):
    built = {"operator": 0, "solver": 0}
    operator_init, solver_init = identify.regressor_design.RegressorOperator.__init__, identify.regressor_design.SquareSolver.__init__

    def count(kind, init):
        def counted(self, *args, **kwargs):
            built[kind] += 1
            init(self, *args, **kwargs)
        return counted

    monkeypatch.setattr(identify.regressor_design.RegressorOperator, "__init__", count("operator", operator_init))
    monkeypatch.setattr(identify.regressor_design.SquareSolver, "__init__", count("solver", solver_init))
    truth = known_model(6)
    design = Design(truth.grid, damped_oscillation(truth.grid, True), True)
    assert built == {"operator": 0, "solver": 0}  # nothing is built until a fit asks
    y = truth.predict(design.inputs)
    rng = np.random.default_rng(1)
    for method in ("cs", "cs_order_nn", "cs_nodct", "ls", "smooth_nn", "cs"):
        rows = np.append(rng.choice(design.n - 1, 14, replace=False), design.n - 1)
        make_method(method).fit(Problem.on(design, y, rows))
    assert built == {"operator": 1, "solver": 1}
    # the shared solver gives what a fresh design's gives
    fresh = make_method("cs").fit(Problem.build(truth.grid, design.inputs, y)).parameters_
    assert built == {"operator": 2, "solver": 2}
    np.testing.assert_array_equal(fresh, make_method("cs").fit(Problem.on(design, y)).parameters_)
    assert built == {"operator": 2, "solver": 2}


def test_nothing_outlives_the_design():
    """No module-level cache: once the design and its problems are gone, so are its operator and solver."""
    assert importlib.util.find_spec("identify.design_cache") is None
    truth = known_model(5)
    design = Design(truth.grid, damped_oscillation(truth.grid, True), True)
    problem = Problem.on(design, truth.predict(design.inputs))
    est = make_method("cs_order_nn").fit(problem)
    operator, solver = weakref.ref(design.operator), weakref.ref(design.square_solver)
    assert operator() is not None and solver() is not None
    del design, problem, est
    gc.collect()
    assert operator() is None and solver() is None


def test_a_used_design_pickles_without_what_it_built():
    truth = known_model(4)
    design = Design(truth.grid, damped_oscillation(truth.grid, True), True, history=[1.0, 0.5])
    design.square_solver
    copy = pickle.loads(pickle.dumps(design))
    assert copy == design and "_square" not in vars(copy) and "operator" not in vars(copy)
    b = np.random.default_rng(2).normal(size=design.n)
    np.testing.assert_array_equal(copy.square_solver.solve(b), design.square_solver.solve(b))


def test_the_study_fits_every_trial_on_one_design(monkeypatch):
    built = []
    init = identify.regressor_design.RegressorOperator.__init__

    def counted(self, *args, **kwargs):
        built.append(args[0].levels)
        init(self, *args, **kwargs)

    monkeypatch.setattr(identify.regressor_design.RegressorOperator, "__init__", counted)
    setup = StudySetup(profile="random", levels=5, measurements=10, runs=3, noise=1.0,
                       methods=("cs", "ls"), validation_points=20)
    results = run_trials(setup, setup.trials())
    assert len(results) == 3 and built == [5]


def test_a_joint_effect_fit_keeps_one_design_across_its_solves(monkeypatch):
    """The Gauss--Newton solves of identify.effects.joint fit on the same hysteron inputs: one operator, the
    fit's own evaluator's, which the solves' designs adopt."""
    from identify import PreisachModel
    from identify.effects import make_effect
    from identify.effects.joint import fit_with_effects
    from identify.runs import Run

    built = []

    class Counted(RegressorOperator):  # the designs' operators and the fit's evaluator's
        def __init__(self, *args, **kwargs):
            built.append(1)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(identify.regressor_design, "RegressorOperator", Counted)
    monkeypatch.setattr(identify.effects.joint, "RegressorOperator", Counted)
    grid = Grid(5, 0.0, 4.0)
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.normal(0.0, 0.7, 200)) % 8.0
    v = np.where(walk > 4.0, 8.0 - walk, walk)
    dwell = rng.choice([5.0, 10.0, 30.0], v.size)
    truth = PreisachModel(grid, rng.uniform(0.1, 1.0, grid.n_cells), mu0=0.3, c_d=-0.4)
    y = truth.predict(v) + 0.01 * np.sin(np.cumsum(dwell) / 300.0)
    fit = fit_with_effects(grid, [Run("sim", v, y, np.cumsum(dwell), dwell, 4, 0.0)], "ls",
                           [make_effect("creep")])
    assert fit.info["solves"] > 1 and len(built) == 1
