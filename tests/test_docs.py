"""The documentation site: every command has a reference page, the links hold, and the site builds
with warnings as errors (Sphinx with MyST; the ``docs`` extra -- without it the build test skips,
saying so; CI installs it)."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from rig.commands import COMMANDS, load

from .forcfiles import REPO

DOCS = REPO / "docs"
#: The user documentation: no project issue numbers, links that resolve.
USER_DOCS = [REPO / "README.md", REPO / "CONTRIBUTING.md", REPO / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
MISSING = [m for m in ("sphinx", "myst_parser", "sphinx_click") if importlib.util.find_spec(m) is None]


def user_docs():
    return [p for p in USER_DOCS if "_build" not in p.parts and p.is_file()]


def test_every_command_has_a_reference_page_generated_from_its_click_definition():
    for entry in COMMANDS:
        page = DOCS / "reference" / "commands" / f"{entry.name}.md"
        assert page.is_file(), f"no reference page for rig {entry.name}"
        text = page.read_text(encoding="utf-8")
        assert f"```{{eval-rst}}\n.. click:: {entry.module}:{entry.attribute}\n   :prog: rig {entry.name}\n" in text, entry.name
        index = (DOCS / "reference" / "commands" / "index.md").read_text(encoding="utf-8")
        assert f"({entry.name}.md)" in index and f"\n{entry.name}\n" in index, entry.name


def test_no_user_document_names_an_issue_number():
    found = {str(p.relative_to(REPO)): m.group(0) for p in user_docs()
             if (m := re.search(r"\bissues? [0-9]+", p.read_text(encoding="utf-8"), re.I))}
    assert not found, found


def test_every_relative_link_in_the_user_documentation_resolves():
    broken = []
    for page in user_docs():
        text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)  # not inside code
        for m in LINK.finditer(text):
            target = (m.group(1) or m.group(2)).split("#")[0]
            if not target or re.match(r"[a-z]+:", target):
                continue
            if not (page.parent / target).exists():
                broken.append(f"{page.relative_to(REPO)}: {target}")
    assert not broken, broken


def test_every_results_page_is_dated_and_names_the_machine_and_the_command():
    pages = sorted((DOCS / "results").glob("*.md"))
    assert len(pages) > 10
    for page in pages:
        if page.name == "index.md":
            continue
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}-[a-z0-9-]+\.md", page.name), page.name
        head = page.read_text(encoding="utf-8")[:2000]
        assert "| measured | machine | reproduce |" in head and "2 cores" in head and "`" in head, page.name


@pytest.mark.slow
@pytest.mark.timeout(240)
@pytest.mark.skipif(bool(MISSING), reason=f"the docs extra is not installed (missing {', '.join(MISSING)}): "
                                          "pip install -e '.[docs]' to build the site")
def test_the_site_builds_without_a_warning(tmp_path):
    out = tmp_path / "html"
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-E", "-b", "html",
                           str(DOCS), str(out)], capture_output=True, text=True, timeout=220, cwd=REPO)
    assert done.returncode == 0, done.stderr[-4000:]
    assert not done.stderr.strip(), done.stderr[-4000:]
    for entry in COMMANDS:  # every command's options, from click, rendered (not left as reST text)
        page = (out / "reference" / "commands" / f"{entry.name}.html").read_text(encoding="utf-8")
        assert ".. option::" not in page, entry.name
        for param in load(entry).params:
            if param.param_type_name == "option" and not param.hidden:
                assert f'id="cmdoption-rig-{entry.name}-{param.opts[0].lstrip("-")}"' in page, (entry.name, param.opts)
    from drivers.config import RigConfig
    from drivers.configschema import describe

    page = (out / "reference" / "rig-toml.html").read_text(encoding="utf-8")
    for key in describe(RigConfig):  # every rig.toml key, with its own description
        assert f">{key['key']}<" in page, key["key"]
        assert key["doc"].split("(")[0].split("'")[0].strip()[:30].replace("&", "&amp;") in page, key["key"]
    assert (out / "reference" / "api.html").read_text(encoding="utf-8").count('class="sig sig-object py"') > 30
