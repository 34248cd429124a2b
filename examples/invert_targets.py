"""The heater voltages that make a model follow a target deflection: the inverse of equation (22).

    python examples/invert_targets.py

Uses the simulated device's own model as the identified one; ``rig invert`` does the same from a
session or a model file.
"""

# %% A model and a target: a slow sine inside the model's reachable range
import numpy as np

from drivers.sim import SimParams, SimVO2
from identify.inverse import invert, output_range

model = SimVO2(SimParams(levels=30)).true_model()
domain = (model.grid.v_min, model.grid.v_max)
lo, hi = output_range(model, domain)
t = np.arange(200) * 5.0
targets = (lo + hi) / 2 + 0.4 * (hi - lo) * np.sin(2 * np.pi * t / 500.0)

# %% Invert from negative saturation, in one call
result = invert(model, targets, t, domain=domain)
print(f"{len(targets)} targets in [{targets.min():.2f}, {targets.max():.2f}] um; "
      f"{result.n_unreachable} unreachable; {1e6 * result.seconds / len(targets):.0f} us per target")

# %% The forward model on the voltages found gives the targets back
reached = model.predict(result.voltages)
print(f"largest |reached - target|: {np.abs(reached - targets).max():.2e} um")
assert result.n_unreachable == 0 and np.abs(reached - targets).max() < 1e-6
