"""Identify equation (22) from 300 of the damped oscillation's 467 points, as in the paper.

Notebook-style: run it cell by cell (``# %%``) in an editor that knows cells, or as a script:

    python examples/identify_simulated.py

The true actuator is the simulated VO2 device's own Preisach model (``drivers.sim``); its outputs
on the damped oscillation get 0.01 um of noise, and every method the damped oscillation allows is
fitted on the same 300 randomly chosen outputs and scored against the noise-free truth.
"""

# %% The true actuator and the identification input
import numpy as np

from drivers.sim import SimParams, SimVO2
from identify import Grid, Problem, choose_rows, damped_oscillation, make_method, random_input

truth = SimVO2(SimParams(levels=30)).true_model()  # a PreisachModel: grid, mu0, c_d, cell weights
grid = Grid(truth.grid.levels, truth.grid.v_min, truth.grid.v_max)
v = damped_oscillation(grid, thermal_term=True)  # N + 1 = 467 inputs (V): the square design
print(f"L = {grid.levels} on [{grid.v_min:g}, {grid.v_max:g}] V: {v.size} inputs")

# %% The measured outputs: the truth plus noise, 300 of them chosen at random
rng = np.random.default_rng(0)
y = truth.predict(v) + rng.normal(0.0, 0.01, v.size)  # deflection (um)
rows = choose_rows(v.size, 300, seed=0, include=(v.size - 1,))  # the thermal point is always measured
problem = Problem.build(grid, v, y, rows=rows, thermal_term=True)

# %% Fit each method and score it on a random input it has never seen
check = random_input(grid, 500, seed=1)
expected = truth.predict(check)
print(f"{'method':12s} {'fit rmse (um)':>14s} {'check rmse (um)':>16s}")
for name in ("ls", "cs_order_nn", "smooth_nn"):
    model = make_method(name).fit(problem).model_
    fit_rmse = np.sqrt(np.mean((model.predict(v)[rows] - y[rows]) ** 2))
    check_rmse = np.sqrt(np.mean((model.predict(check) - expected) ** 2))
    print(f"{name:12s} {fit_rmse:14.5f} {check_rmse:16.5f}")
    assert check_rmse < 0.5, name  # far below the 30 um swing of the actuator
