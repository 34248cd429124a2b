"""Record a short run with the command line, then read the session and its stored model in Python.

    python examples/read_session.py [SESSION.h5]

Without an argument it records a damped oscillation of L = 8 levels on the simulated rig (virtual
clock: well under a second) and identifies it, both with ``rig``, in a temporary directory.
"""

# %% A session: yours, or one recorded now
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from sessions import read_session

if len(sys.argv) > 1:
    path = Path(sys.argv[1])
else:
    path = Path(tempfile.mkdtemp()) / "s.h5"
    rig = [sys.executable, "-m", "rig"]
    subprocess.run([*rig, "acquire", "-L", "8", "--dwell", "5", "-o", path, "--no-progress"], check=True,
                   capture_output=True)
    subprocess.run([*rig, "identify", path, "--method", "smooth_nn"], check=True, capture_output=True)

# %% What the session holds: every applied point, the measured ones, the plan, the log, the models
s = read_session(path)
print(f"{path.name}: {s.status.value}, {s.n_samples} points ({int(s.measured.sum())} measured), "
      f"{s.excitation.kind} excitation, L = {s.excitation.levels}, started {s.started_at}")
print(f"input {s.quantities.input_unit}, output {s.quantities.output_unit}; models: {', '.join(s.models) or 'none'}")
for event in s.events:
    print(f"  log: {event.status.value:9s} {event.event}: {event.message}")

# %% A stored model predicts the run from negative saturation, as rig validate does
if s.models:
    record = list(s.models.values())[-1]
    error = record.model.predict(s.inputs)[s.measured] - s.outputs[s.measured]
    print(f"model {record.name!r} ({record.method}): rmse {np.sqrt(np.mean(error ** 2)):.4g} {s.quantities.output_unit}")
    assert np.sqrt(np.mean(error ** 2)) < 0.5
