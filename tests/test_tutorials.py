"""The tutorials that record their own runs on the simulated rig, run as written: every ``sh`` line, in
order, in an empty directory (``docs/bench.md`` has its own test, against ``rig serve-sim``)."""

from __future__ import annotations

import subprocess

import pytest

from .doc_blocks import argv, sh_lines
from .forcfiles import REPO

TUTORIALS = REPO / "docs" / "tutorials"


def run_page(name: str, cwd) -> dict[str, subprocess.CompletedProcess]:
    done_by_line = {}
    for line in sh_lines((TUTORIALS / name).read_text(encoding="utf-8")):
        done = subprocess.run(argv(line), cwd=cwd, capture_output=True, text=True, timeout=240)
        assert done.returncode == 0, (line, done.stdout[-2000:], done.stderr[-2000:])
        done_by_line[line] = done
    return done_by_line


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_re_identifying_a_session_offline_runs_as_written(tmp_path):
    done = run_page("reidentify.md", tmp_path)
    assert len(done) >= 9
    from sessions import read_session

    stored = set(read_session(tmp_path / "S.h5").models)
    assert {"ls", "smooth_nn-M300-s0", "cs_order_nn-M300-s1", "ls-batch"} <= stored, stored
    assert (tmp_path / "report" / "report.md").is_file()


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_diagnosing_a_gap_runs_as_written_and_names_the_effect_it_switched_on(tmp_path):
    done = run_page("diagnose.md", tmp_path)
    verdict = next(d.stdout for line, d in done.items() if line.startswith("rig diagnose"))
    assert "Verdict: EXPLAINED by creep" in verdict
    assert (tmp_path / "diagnosis" / "where.png").is_file()
