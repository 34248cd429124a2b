"""The house: what the repository holds and how it is installed (issue 17, findings 1-2 and "The house")."""

from __future__ import annotations

import os
import re
from pathlib import Path

from .forcfiles import REPO, SHARED_FORC

#: Directories that are not the project's own files.
NOT_OURS = {".git", ".ci-venv", ".venv", "__pycache__", ".pytest_cache", ".hypothesis", "build", "dist"}
#: An absolute path on a developer's or the CI's machine.
MACHINE_PATH = re.compile(r"(?<![\w.~-])/(?:work|home|root|Users)/[\w.-]+")


def project_text_files():
    for root, dirs, files in os.walk(REPO):
        dirs[:] = [d for d in dirs if d not in NOT_OURS and not d.endswith(".egg-info")]  # not into venvs
        for name in files:
            path = Path(root) / name
            if path.suffix in {".py", ".md", ".toml", ".cfg", ".txt", ".sh"} or name == "run":
                yield path


def test_no_file_names_an_absolute_machine_path():
    # issue 17, finding 2: an absolute path to the shared data made the real-data tests skip silently in
    # every other clone
    found = {}
    for path in project_text_files():
        hits = MACHINE_PATH.findall(path.read_text(encoding="utf-8", errors="replace"))
        if hits:
            found[str(path.relative_to(REPO))] = sorted(set(hits))
    assert not found, found


def test_the_shared_measurement_is_found_relative_to_the_repository():
    assert SHARED_FORC == REPO.parent / "shared" / "data" / "forc" / "MD00-2361.forc"
    assert SHARED_FORC.is_file(), f"{SHARED_FORC} is missing: CI and every clone have ../shared beside the repository"


def test_benchmarks_are_scripts_not_an_installed_package(tmp_path):
    # the house: benchmarks/ was installed as a top-level package because rig bench imported it
    import subprocess
    import sys
    import tomllib

    packages = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    assert not any(p.startswith("benchmarks") for p in packages["include"])
    assert not (REPO / "benchmarks" / "__init__.py").exists()
    code = "import importlib.util, sys; sys.stdout.write(str(importlib.util.find_spec('benchmarks')))"
    # installed means found without the checkout on the path: a PYTHONPATH naming the checkout (a worktree's
    # tests run so) finds benchmarks/ as a namespace package, installed or not
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=60,
                          env=env)
    assert done.stdout == "None", done.stdout + done.stderr
    # every script runs from its file (from a checkout: the repository's packages, or benchmarks/ as a
    # namespace package from the root, as `python -m benchmarks.withheld.run` does)
    for script in sorted((REPO / "benchmarks").glob("*.py")):
        text = script.read_text(encoding="utf-8")
        compile(text, str(script), "exec")
        assert not re.search(r"^\s*from \.", text, re.M), script.name  # run as a file, a relative import fails
    done = subprocess.run([sys.executable, str(REPO / "benchmarks" / "cold_start.py"), "--help"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0 and "usage" in done.stdout, done.stderr[-500:]
