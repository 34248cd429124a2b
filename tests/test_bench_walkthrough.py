"""docs/bench.md, run as written (issue 17, finding 10): every ``sh`` block, in order, each line as a bench
operator would paste it, against ``rig serve-sim``.

The one liberty taken: the example configurations copied into the working
directory listen on ports the system chose free (5020 may be taken on a
shared machine); the commands themselves are run verbatim.
"""

from __future__ import annotations

import re
import shutil
import signal
import socket
import subprocess

import pytest

from .doc_blocks import argv, sh_lines
from .forcfiles import REPO

BENCH = REPO / "docs" / "bench.md"


def steps() -> list[str]:
    """Every command line of the walk-through's ``sh`` blocks, in order (comments dropped)."""
    return sh_lines(BENCH.read_text(encoding="utf-8"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_bench_walkthrough_runs_as_written(tmp_path):
    lines = steps()
    assert [ln.split()[:2] for ln in lines] == [
        ["cp", "docs/rig.toml"], ["rig", "serve-sim"], ["rig", "selftest"], ["rig", "acquire"], ["rig", "acquire"],
        ["rig", "identify"], ["rig", "validate"], ["rig", "report"], ["rig", "diagnose"]]
    (tmp_path / "docs").mkdir()
    for example in (REPO / "docs").glob("*.toml"):
        text = example.read_text(encoding="utf-8").replace(":5020", f":{free_port()}")
        text = re.sub(r"^port = 5020", f"port = {free_port()}", text, flags=re.M)
        (tmp_path / "docs" / example.name).write_text(text.replace(":5021", f":{free_port()}"), encoding="utf-8")
    background: list[subprocess.Popen] = []
    outputs: dict[str, subprocess.CompletedProcess] = {}
    try:
        for line in lines:
            if line.endswith("&"):
                proc = subprocess.Popen(argv(line[:-1]), cwd=tmp_path, stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True)
                background.append(proc)
                assert proc.stdout.readline(), proc.stderr.read()  # it listens once it prints an endpoint
                continue
            done = subprocess.run(argv(line), cwd=tmp_path, capture_output=True, text=True, timeout=180)
            assert done.returncode == 0, (line, done.stdout, done.stderr)
            outputs[line] = done
    finally:
        for proc in background:
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=30)
    assert background and background[0].returncode == 0 and "heater at 0 V" in err
    by = {line.split()[1]: done for line, done in outputs.items() if line.startswith("rig ")}
    assert "PASSED" in by["selftest"].stdout
    acquired = [done for line, done in outputs.items() if line.startswith("rig acquire")]
    for done in acquired:  # the planned time is shown before the run
        assert done.stderr.startswith("plan: ") and "rig time" in done.stderr.splitlines()[0]
    assert "stored as /models/smooth_nn" in by["identify"].stdout
    assert "nrmse" in by["validate"].stdout
    assert (tmp_path / "report" / "report.md").is_file() and (tmp_path / "diagnosis" / "where.png").is_file()
    assert "Verdict" in by["diagnose"].stdout
    assert shutil.which("cp")
