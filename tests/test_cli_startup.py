"""Start-up: a command imports what it needs and nothing else (issue 17, finding 3).

Timing is measured by ``benchmarks/cold_start.py``, not asserted here; what
is asserted is the cause of a slow start: which packages a fresh process
imports to run a command.
"""

from __future__ import annotations

import inspect
import json
import subprocess
import sys

import pytest

from rig.commands import BY_NAME, COMMANDS, load

from .cli import rig_here

#: Packages no command needs merely to start.
HEAVY = ("numpy", "scipy", "h5py", "identify", "sessions", "drivers", "pymodbus", "serial", "matplotlib",
         "cvxpy", "clarabel", "tqdm")


#: What scipy's import used to bring along (numpy's test and Fortran-wrapper tools, see :mod:`rig.numpy_tools`),
#: what only writing a session needs (``importlib.metadata``, with ``email``) and the interior-point solver
#: that only some fits run: a command that does not use them must not start by importing them.
UNUSED_AT_START = {"numpy.f2py.f2py2e", "numpy.testing._private", "charset_normalizer", "unittest", "email",
                   "clarabel", "cvxpy"}


def imported_by(args: list[str], cwd) -> set[str]:
    """Top-level packages (and scipy and numpy submodules) a fresh interpreter has imported after ``rig ARGS``.

    A module that :mod:`rig.numpy_tools` made lazy is listed though it has not run; what it would import
    (``numpy.f2py.f2py2e``, ``numpy.testing._private``) is not."""
    code = (
        "import json, sys\n"
        "from rig.cli import main\n"
        f"sys.argv = ['rig', *{args!r}]\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "names = {m.split('.')[0] for m in sys.modules} | {m for m in sys.modules if m.startswith(('scipy.', 'numpy.'))}\n"
        "sys.stderr.write(json.dumps(sorted(names)))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=120)
    return set(json.loads(done.stderr.strip().splitlines()[-1]))


@pytest.mark.parametrize("args", [["--version"], ["--help"]])
def test_version_and_help_import_no_numerics_drivers_or_files(args, tmp_path):
    loaded = imported_by(args, tmp_path)
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_identify_imports_neither_the_drivers_nor_the_plots_nor_the_dense_solvers(tmp_path):
    session = tmp_path / "s.h5"
    assert rig_here("acquire", "--levels", "6", "--out", session, "--no-progress").code == 0
    loaded = imported_by(["identify", str(session), "--method", "cs_nodct", "--no-store"], tmp_path)
    assert {"numpy", "scipy", "h5py", "identify", "sessions"} <= loaded  # it did run
    unwanted = {"drivers", "pymodbus", "serial", "matplotlib", "cvxpy", "tqdm", "scipy.optimize", "scipy.stats",
                "scipy.fft", "scipy.interpolate", "scipy.spatial"} | UNUSED_AT_START
    assert not loaded & unwanted, sorted(loaded & unwanted)


def test_identify_help_imports_no_solver_nor_test_tools(tmp_path):
    loaded = imported_by(["identify", "--help"], tmp_path)
    assert "scipy" in loaded  # the method registry: identify and its operators
    unwanted = {"drivers", "matplotlib", "tqdm", "scipy.optimize", "scipy.stats", "scipy.fft", "scipy.special",
                "scipy.interpolate", "scipy.spatial"} | UNUSED_AT_START
    assert not loaded & unwanted, sorted(loaded & unwanted)


def test_least_squares_imports_scipy_optimize_for_its_nnls_and_no_more(tmp_path):
    # scipy.optimize (and what it imports: scipy.special, scipy.fft, scipy.spatial) stays: 'ls' solves with
    # scipy's NNLS, and the repository's Lawson-Hanson agrees with it only to rounding (docs/results,
    # 2026-11-28-cold-start)
    session = tmp_path / "s.h5"
    assert rig_here("acquire", "--levels", "6", "--out", session, "--no-progress").code == 0
    loaded = imported_by(["identify", str(session), "--method", "ls", "--no-store"], tmp_path)
    assert "scipy.optimize" in loaded
    unwanted = {"drivers", "matplotlib", "tqdm", "scipy.stats", "scipy.interpolate"} | UNUSED_AT_START
    assert not loaded & unwanted, sorted(loaded & unwanted)


def test_deferred_numpy_tools_still_work_when_used(tmp_path):
    code = ("from rig.numpy_tools import defer_numpy_tools\n"
            "defer_numpy_tools()\n"
            "import sys, numpy, scipy.sparse\n"
            "assert 'numpy.testing._private' not in sys.modules\n"
            "numpy.testing.assert_allclose(1.0, 1.0)\n"
            "from numpy.f2py import get_include\n"
            "print(numpy.testing.assert_allclose.__module__, callable(get_include))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["numpy.testing._private.utils", "True"]


def test_help_lists_every_command_with_its_own_first_sentence():
    for entry in COMMANDS:
        command = load(entry)
        first = inspect.cleandoc(command.help).split("\n\n")[0].replace("\n", " ")
        assert entry.short_help == first, entry.name
        assert command.name == entry.name
    operator, research = rig_here("--help").out.split("Commands:\n")[1].split("Research commands:\n")
    listed = [[line.split()[0] for line in section.splitlines() if line.startswith("  ") and line.strip()]
              for section in (operator, research)]
    assert listed == [sorted(n for n, e in BY_NAME.items() if not e.research), ["bench", "study"]]
    assert sorted(listed[0] + listed[1]) == sorted(BY_NAME)  # every command, once
