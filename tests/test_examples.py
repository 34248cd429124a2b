"""Every script in examples/ runs as a user runs it, from a fresh interpreter, and checks its own result."""

from __future__ import annotations

import subprocess
import sys

import pytest

from .forcfiles import REPO

EXAMPLES = sorted((REPO / "examples").glob("*.py"))


def test_there_are_examples_and_the_python_api_tutorial_shows_each():
    assert len(EXAMPLES) >= 4
    tutorial = (REPO / "docs" / "tutorials" / "python-api.md").read_text(encoding="utf-8")
    for script in EXAMPLES:
        assert f"examples/{script.name}" in tutorial, script.name


@pytest.mark.slow
@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_the_example_runs(script, tmp_path):
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert done.stdout.strip()  # it shows what it did
