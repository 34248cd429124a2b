"""Shared test helpers."""

from __future__ import annotations

import os

# One BLAS thread per test process: the suite runs a worker per core (pytest-xdist), and BLAS threads on
# top of them oversubscribe the cores (on the two shared cores a 465 x 465 factorisation took 130 ms
# instead of 1.7 ms); the rig processes the tests start inherit it.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import signal  # noqa: E402

# Ctrl-C as at an operator's terminal: a shell without job control starts a background command (`pytest &`,
# `nohup pytest &` from a script) with SIGINT ignored, Python then never raises KeyboardInterrupt, and the
# rig processes the tests start inherit the disposition -- the interrupt tests would measure the launcher,
# not the program. A handler (not SIG_IGN) here is reset to the default in every process exec'd from here.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

import hashlib  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from identify import Grid, PreisachModel  # noqa: E402


def write_csv(path: Path, v, y, t=None) -> Path:
    v = np.asarray(v, dtype=float)
    t = np.arange(v.size, dtype=float) if t is None else t
    lines = ["t_s,v_V,deflection_um"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, v, y)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def known_model(levels: int, v_min: float = 0.0, v_max: float = 5.0, seed: int = 0,
                mu0: float = -1.25, c_d: float = 0.75) -> PreisachModel:
    """A model with strictly positive random density, negative bias, thermal term."""
    grid = Grid(levels, v_min, v_max)
    rng = np.random.default_rng(seed)
    return PreisachModel(grid, rng.uniform(0.5, 3.0, grid.n_cells), mu0=mu0, c_d=c_d)


@pytest.fixture
def tmp_csv(tmp_path):
    def make(v, y, name="trace.csv", t=None):
        return write_csv(tmp_path / name, v, y, t)

    return make


@pytest.fixture(scope="session", autouse=True)
def instrument_locks(tmp_path_factory):
    """The one-run-per-instrument locks of this test session (and of its child processes) live here."""
    os.environ["RIG_LOCK_DIR"] = str(tmp_path_factory.mktemp("instrument-locks"))
