"""Sphinx configuration of the vo2rig documentation (MyST Markdown; build: see CONTRIBUTING.md)."""

from __future__ import annotations

import sys
from importlib.metadata import version as _version
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE / "_ext")]  # the packages (for autodoc) and rigdocs

project = "vo2rig"
author = "the vo2rig developers"
copyright = "2026, the vo2rig developers (MIT licence)"
release = _version("vo2rig")

extensions = [
    "myst_parser",  # pages are Markdown that reads as well in the repository
    "sphinx.ext.autodoc",  # the Python API from its docstrings
    "sphinx_click",  # every rig command from its click definition
    "rigdocs",  # rig.toml from the configuration schema
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext"]
myst_heading_anchors = 3  # links to headings (page.md#a-heading), as GitHub renders them
myst_enable_extensions = ["dollarmath"]
smartquotes = False  # keep --force, not an en dash, in the text sphinx-click takes from the help

autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "description"
autodoc_class_signature = "separated"
toc_object_entries = False  # the sidebar lists the pages, not every documented function

html_theme = "alabaster"
html_title = f"vo2rig {release}"
html_theme_options = {"description": "Preisach hysteresis identification for a VO2 microactuator rig",
                      "fixed_sidebar": True}
html_sidebars = {"**": ["about.html", "navigation.html", "relations.html", "searchbox.html"]}
