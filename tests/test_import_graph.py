"""The import graph of ``identify``, ``interrupts``, ``drivers``, ``sessions`` and ``rig``: no circle, no upward
import, and library code never imports a CLI command.

Read from the source with :mod:`ast`, every import counted wherever it stands -- at module level, inside a
function (the lazy imports that keep start-up fast), or under ``TYPE_CHECKING``: each is a dependency a
reader has to follow.  ``from P import name`` is an import of the module ``P.name`` when there is one, else of
``P``; and an import of ``a.b.c`` is one of the packages ``a`` and ``a.b`` too (Python runs their
``__init__`` first), unless the importer stands inside them."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: The packages whose graph is checked.
PACKAGES = ("identify", "interrupts", "drivers", "sessions", "rig")
#: Floors: a package imports only packages of lower floors (and itself); ``identify`` (pure numerics) and
#: ``interrupts`` are the ground floor, ``drivers`` and ``sessions`` stand side by side on it, ``rig`` on top.
FLOOR = {"identify": 0, "interrupts": 0, "drivers": 1, "sessions": 1, "rig": 2}
#: Inside ``drivers``: the backends, one package each, stand on the modules directly in ``drivers/`` (what a
#: backend is, channels, limits, links, the schema); the assembly stands on the backends.
BACKENDS = ("drivers.sim", "drivers.modbus", "drivers.serial")
ASSEMBLY = ("drivers", "drivers.config", "drivers.rig", "drivers.selftest")


def _modules() -> dict[str, tuple[Path, bool]]:
    """Every module of :data:`PACKAGES`: ``{dotted name: (file, is a package)}``."""
    out = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = list(path.relative_to(REPO).with_suffix("").parts)
            is_package = parts[-1] == "__init__"
            out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


MODULES = _modules()


def _imports(name: str) -> Iterator[str]:
    """The modules ``name`` imports (this project's by module, anything else by top-level package)."""
    path, is_package = MODULES[name]
    here = name.split(".") if is_package else name.split(".")[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = here[: len(here) - node.level + 1] if node.level else []
            prefix = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                sub = f"{prefix}.{alias.name}"
                yield sub if sub in MODULES else prefix


def _within(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def _with_packages(name: str, targets: set[str]) -> set[str]:
    """``targets`` and the packages above each that importing it runs and ``name`` does not stand inside."""
    out = set(targets)
    for target in targets:
        parts = target.split(".")
        out |= {p for k in range(1, len(parts)) if (p := ".".join(parts[:k])) in MODULES and not _within(name, p)}
    return out


GRAPH = {name: sorted(_with_packages(name, set(_imports(name))) - {name}) for name in MODULES}


def _cycles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
            if w not in MODULES:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in MODULES:
        if v not in index:
            visit(v)
    return found


def test_the_graph_is_read():
    assert "rig.commands" in GRAPH["rig.cli"]
    assert "drivers.config" in GRAPH["drivers.rig"]  # a relative import, resolved
    assert "drivers.modbus" in GRAPH["drivers.config"]  # from . import modbus: the subpackage
    assert "interrupts" in GRAPH["sessions.writer"] and "h5py" in GRAPH["sessions.writer"]
    assert "rig.model_file" in GRAPH["rig.tracking.source"]  # an import inside a function counts
    assert "identify.model" in GRAPH["identify"]
    assert "identify.methods" in GRAPH["identify.fit"]  # from .methods import ...: the package
    assert "identify.methods" in GRAPH["identify.diagnosis.base"]  # the package a submodule's import runs


def test_no_circle():
    # between packages a circle would need an upward import (tested below)
    assert [c for c in _cycles() if not all(_within(m, "identify") for m in c)] == []


def test_no_circle_inside_identify():
    # the effects and the fast forward model know the model by the shape they read of it
    # (identify.effects.base.HostModel, identify.forward.Equation22), not by importing it
    assert [c for c in _cycles() if all(_within(m, "identify") for m in c)] == []


@pytest.mark.parametrize("package", PACKAGES)
def test_no_upward_import_between_packages(package):
    upward = {(name, target) for name, targets in GRAPH.items() if _within(name, package)
              for target in targets if (top := target.split(".")[0]) in FLOOR and top != package
              and FLOOR[top] >= FLOOR[package]}
    assert upward == set()


def test_inside_drivers_the_ground_floor_imports_no_backend_and_a_backend_not_the_assembly():
    ground = [m for m in MODULES if _within(m, "drivers") and m not in ASSEMBLY
              and not any(_within(m, b) for b in BACKENDS)]
    assert "drivers.backends" in ground and "drivers.channels" in ground
    bad = {(m, t) for m in ground for t in GRAPH[m] if t in ASSEMBLY or any(_within(t, b) for b in BACKENDS)}
    bad |= {(m, t) for m in MODULES if any(_within(m, b) for b in BACKENDS) for t in GRAPH[m] if t in ASSEMBLY}
    assert bad == set()


def test_library_code_never_imports_a_cli_command():
    # the commands are loaded by name from their registry (rig/commands/__init__.py), by the rig group only
    bad = {(m, t) for m, targets in GRAPH.items() for t in targets
           if _within(t, "rig.commands") and not _within(m, "rig.commands") and m != "rig.cli"}
    assert bad == set()
