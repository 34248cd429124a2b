"""Shared test helpers."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from identify import Grid, PreisachModel


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


@pytest.fixture(scope="session", autouse=True)
def instrument_locks(tmp_path_factory):
    """The one-run-per-instrument locks of this test session (and of its child processes) live here."""
    os.environ["RIG_LOCK_DIR"] = str(tmp_path_factory.mktemp("instrument-locks"))


@pytest.fixture
def tmp_csv(tmp_path):
    def make(v, y, name="trace.csv", t=None):
        return write_csv(tmp_path / name, v, y, t)

    return make
