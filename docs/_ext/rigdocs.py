"""Reference pages generated from the code: the ``rig.toml`` keys from the configuration schema.

``config_tables()`` walks :class:`drivers.config.RigConfig` -- the dataclasses whose fields are
declared with :func:`drivers.configschema.setting` -- and returns every table with its own
description and every key with its type, unit, default and description, as the schema says them:
the reference cannot drift from what ``rig.toml`` accepts.  It needs no Sphinx (a test calls it);
:func:`setup` registers the ``rig-toml-reference`` directive that renders it.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from typing import Any, NamedTuple


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


def _inner(tp: Any) -> tuple[Any, bool]:
    """The type inside ``X | None``, and whether it was optional."""
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return tp, False


def _type_name(tp: Any) -> str:
    inner, _ = _inner(tp)
    if inner is dict or typing.get_origin(inner) is dict:
        return "table"
    return {float: "number", int: "integer", str: "string", bool: "boolean"}.get(inner, str(inner))


def _default(field: dataclasses.Field, required: bool) -> str:
    if required:
        return "**required**"
    value = field.default if field.default is not dataclasses.MISSING else field.default_factory()
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


def config_tables(cls: type | None = None, name: str = "", meaning: str = "the top level",
                  optional: bool = False) -> list[Table]:
    """Every table of ``rig.toml`` (``cls``: its dataclass, default :class:`RigConfig`), depth first."""
    if cls is None:
        from drivers.config import RigConfig

        cls = RigConfig
    hints = typing.get_type_hints(cls)
    keys: list[Key] = []
    nested: list[Table] = []
    for field in dataclasses.fields(cls):
        if not field.init:  # bookkeeping such as RigConfig.source, not a key
            continue
        key = f"{name}.{field.name}" if name else field.name
        inner, is_optional = _inner(hints[field.name])
        doc = field.metadata.get("doc", "")
        if dataclasses.is_dataclass(inner):
            nested += config_tables(inner, key, _strip_table_name(doc), optional or is_optional)
            continue
        required = field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING
        if key == "sim.effects":
            from drivers.sim import EFFECTS

            doc = f"{doc}; built in: {', '.join(f'`{e}`' for e in EFFECTS)}"
        keys.append(Key(key, _type_name(hints[field.name]), field.metadata.get("unit", ""),
                        _default(field, required), doc))
    return [Table(name, meaning, optional, keys), *nested]


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
