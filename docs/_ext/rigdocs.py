"""Reference pages generated from the code: the ``rig.toml`` keys from the configuration schema.

``config_tables()`` groups :func:`drivers.configschema.describe`'s keys -- the fields of
:class:`drivers.config.RigConfig` declared with :func:`drivers.configschema.setting` -- by their
table, each table with its own description: every key with its type, unit, default and
description, as the schema says them, so the reference cannot drift from what ``rig.toml``
accepts.  It needs no Sphinx (a test calls it); :func:`setup` registers the
``rig-toml-reference`` directive that renders it.
"""

from __future__ import annotations

import dataclasses
import typing
from typing import Any, NamedTuple

# the schema's own reading of a field's type (an optional table is ``Table | None``)
from drivers.configschema import _is_table, _unwrap_optional, describe


class Key(NamedTuple):
    key: str
    type: str
    unit: str
    default: str
    meaning: str


class Table(NamedTuple):
    name: str  # "" for the top level
    meaning: str
    optional: bool
    keys: list[Key]


def _default(row: dict[str, Any]) -> str:
    """A key's default as the reference shows it, from :func:`describe`'s row."""
    value = row["default"]
    if row["required"]:
        return "**required**"
    if value is None:
        return "--"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, float):
        return f"`{value:g}`"
    if isinstance(value, str):
        return f"`{value!r}`" if not value.isprintable() or not value.strip() else f"`{value}`"
    if isinstance(value, dict):
        return "empty" if not value else f"`{value}`"
    return f"`{value}`"


def _strip_table_name(doc: str) -> str:
    """``"[heater] heater output limits"`` -> ``"heater output limits"``."""
    return doc.split("] ", 1)[1] if doc.startswith("[") and "] " in doc else doc


def _tables(cls: type, name: str, meaning: str, optional: bool) -> list[tuple[str, str, bool]]:
    """``(name, meaning, optional)`` of the table ``cls`` and of every table nested in it, depth first,
    read as the schema reads a field's type."""
    out = [(name, meaning, optional)]
    hints = typing.get_type_hints(cls)
    for field in dataclasses.fields(cls):
        inner, is_optional = _unwrap_optional(hints[field.name])
        if field.init and _is_table(inner):
            key = f"{name}.{field.name}" if name else field.name
            out += _tables(inner, key, _strip_table_name(field.metadata.get("doc", "")), optional or is_optional)
    return out


def config_tables() -> list[Table]:
    """Every table of ``rig.toml`` with its keys (:func:`describe`'s rows), in the schema's order."""
    from drivers.config import RigConfig
    from drivers.sim import EFFECTS

    rows = describe(RigConfig)
    out = []
    for name, meaning, optional in _tables(RigConfig, "", "the top level", False):
        keys = []
        for row in rows:
            if (row["key"].rsplit(".", 1)[0] if "." in row["key"] else "") != name:
                continue
            doc = row["doc"]
            if row["key"] == "sim.effects":
                doc = f"{doc}; built in: {', '.join(f'`{e}`' for e in EFFECTS)}"
            keys.append(Key(row["key"], row["type"], row["unit"], _default(row), doc))
        out.append(Table(name, meaning, optional, keys))
    return out


def setup(app):  # pragma: no cover - run by Sphinx
    from docutils import nodes
    from docutils.parsers.rst import Directive

    def cell(text: str) -> nodes.entry:
        entry = nodes.entry()
        para = nodes.paragraph()
        # `code` and **bold** spans, as the table cells above write them
        for i, chunk in enumerate(text.split("`")):
            if i % 2:
                para += nodes.literal(chunk, chunk)
            elif chunk.startswith("**") and chunk.endswith("**"):
                para += nodes.strong(chunk[2:-2], chunk[2:-2])
            elif chunk:
                para += nodes.Text(chunk)
        entry += para
        return entry

    def table(header: list[str], rows: list[list[str]], widths: list[int]) -> nodes.table:
        out = nodes.table()
        group = nodes.tgroup(cols=len(header))
        out += group
        for w in widths:
            group += nodes.colspec(colwidth=w)
        head = nodes.thead()
        group += head
        row = nodes.row()
        for h in header:
            row += cell(h)
        head += row
        body = nodes.tbody()
        group += body
        for values in rows:
            row = nodes.row()
            for v in values:
                row += cell(v)
            body += row
        return out

    class RigTomlReference(Directive):
        """Every ``rig.toml`` table and key, from the configuration schema."""

        def run(self):
            out = []
            for t in config_tables():
                lead = nodes.paragraph()
                if t.name:
                    lead += nodes.strong("", "", nodes.literal(f"[{t.name}]", f"[{t.name}]"))
                    lead += nodes.Text(f" -- {t.meaning}" + (" (optional table)" if t.optional else ""))
                else:
                    lead += nodes.strong("The top level", "The top level")
                    lead += nodes.Text(" -- keys outside any table")
                out.append(lead)
                if t.keys:
                    rows = [[f"`{k.key}`", k.type, k.unit, k.default, k.meaning] for k in t.keys]
                    out.append(table(["key", "type", "unit", "default", "meaning"], rows, [24, 8, 6, 14, 48]))
            return out

    app.add_directive("rig-toml-reference", RigTomlReference)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
