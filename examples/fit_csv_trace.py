"""Fit your own CSV trace (``t_s,v_V,deflection_um``) from Python, and save the model as JSON.

    python examples/fit_csv_trace.py [TRACE.csv]

Without an argument it first writes a small trace of the simulated device to a temporary
directory, so the script runs anywhere. The model file it writes is the one ``rig predict``,
``rig invert`` and ``rig track`` read.
"""

# %% A trace: yours, or one recorded from the simulated device
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from drivers.sim import SimParams, SimVO2
from identify import Grid, Problem, make_method, random_input
from identify.model_json import model_to_dict
from sessions import Trace, read_trace, write_trace

if len(sys.argv) > 1:
    path = Path(sys.argv[1])
else:
    path = Path(tempfile.mkdtemp()) / "trace.csv"
    truth = SimVO2(SimParams(levels=20)).true_model()
    v = random_input(truth.grid, 400, seed=3)
    write_trace(path, Trace(np.arange(v.size) * 20.0, v, truth.predict(v)))
trace = read_trace(path)
print(f"{path}: {len(trace)} samples, input {trace.v_V.min():.3g}..{trace.v_V.max():.3g} V")

# %% The grid spans the measured inputs; smooth_nn fits any input history
grid = Grid(20, float(trace.v_V.min()), float(trace.v_V.max()))
problem = Problem.build(grid, trace.v_V, trace.deflection_um)
model = make_method("smooth_nn").fit(problem).model_
error = model.predict(trace.v_V) - trace.deflection_um
print(f"fit rmse {np.sqrt(np.mean(error ** 2)):.4g} um over {len(trace)} points")

# %% Save it as a model file (what `rig identify -o MODEL.json` writes)
out = path.with_suffix(".model.json")
out.write_text(json.dumps(model_to_dict(model), indent=1) + "\n", encoding="utf-8")
print(f"wrote {out}")
assert np.sqrt(np.mean(error ** 2)) < 0.5
