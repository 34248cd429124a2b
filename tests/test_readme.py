"""The README: the two set-up commands at the top, short, pointing into the documentation, and its
tour of the bench run as written (on the simulated rig)."""

from __future__ import annotations

import re
import shlex
import subprocess

import pytest

from .doc_blocks import BLOCK, argv
from .forcfiles import REPO

README = (REPO / "README.md").read_text(encoding="utf-8")
BLOCKS = BLOCK.findall(README)

#: The five tasks a new user comes for, and the page the README sends them to for each.
TASKS = {
    "install and try": "docs/tutorials/demo.md",
    "acquire, identify, validate and report at the bench": "docs/bench.md",
    "configure a real DAQ (Modbus or serial)": "docs/how-to/configure-daq.md",
    "fit your own CSV or FORC file": "docs/how-to/import-data.md",
    "read a diagnosis verdict": "docs/tutorials/diagnose.md#3-read-the-verdict",
    "troubleshoot an error": "docs/how-to/troubleshoot.md",
}


def test_the_two_setup_commands_open_the_readme_unchanged():
    assert BLOCKS[0] == "pip install -e . && rig demo\npip install -e '.[test]' && pytest\n"
    assert README.index("```sh") < 100  # right under the title
    assert "pip install -e '.[test]' && pytest" in (REPO / ".ci" / "run").read_text(encoding="utf-8")


def test_the_readme_is_short_and_points_into_the_docs():
    assert len(README.splitlines()) <= 200
    for task, page in TASKS.items():
        row = next((ln for ln in README.splitlines() if ln.startswith(f"| {task} |")), None)
        assert row and f"]({page})" in row, task
        assert (REPO / page.split("#")[0]).is_file(), page
    for name in ("LICENSE", "CHANGELOG.md", "CONTRIBUTING.md"):
        assert f"]({name})" in README and (REPO / name).is_file()
    assert "Smart\nMater. Struct. 25 (2016) 075008" in README or "Smart Mater. Struct. 25 (2016) 075008" in README


def test_every_command_has_its_line_in_the_readme():
    from rig.commands import COMMANDS

    table = README.split("## Commands")[1].split("\n## ")[0]
    for entry in COMMANDS:
        assert f"`rig {entry.name}`" in table, entry.name


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_tour_runs_as_written(tmp_path):
    tour = BLOCKS[1]
    lines = [ln for ln in tour.splitlines() if ln.strip()]
    assert [shlex.split(ln, comments=True)[:2] for ln in lines] == [
        ["rig", "acquire"], ["rig", "acquire"], ["rig", "identify"], ["rig", "validate"], ["rig", "diagnose"],
        ["rig", "report"]]
    outputs = {}
    for line in lines:
        done = subprocess.run(argv(line), cwd=tmp_path, capture_output=True, text=True, timeout=240)
        assert done.returncode == 0, (line, done.stdout[-2000:], done.stderr[-2000:])
        outputs[line.split()[1]] = done.stdout
    assert "stored as /models/smooth_nn" in outputs["identify"]
    assert "nrmse" in outputs["validate"] and "Verdict" in outputs["diagnose"]
    assert (tmp_path / "report" / "report.md").is_file() and (tmp_path / "diagnosis" / "where.png").is_file()
