"""A tiny declarative schema for TOML tables: dataclasses whose fields say what they mean.

Each configuration table is a frozen, keyword-only dataclass; each key is a
field declared with :func:`setting` (its documentation, unit, allowed values
and bounds).  :func:`parse_table` turns a parsed TOML table into the
dataclass, rejecting unknown keys (with a "did you mean") and missing
required ones, always naming the key.  :func:`describe` lists every key for
the documentation (the ``rig.toml`` reference, ``docs/reference/rig-toml.md``, is
generated from these declarations).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from typing import Any

from .errors import ConfigError

REQUIRED = dataclasses.MISSING


def setting(
    doc: str,
    *,
    default: Any = REQUIRED,
    default_factory: Any = REQUIRED,
    unit: str = "",
    choices: tuple[Any, ...] | None = None,
    minimum: float | None = None,
    maximum: float | None = None,
    positive: bool = False,
) -> Any:
    """A documented configuration key (a dataclass field); required unless a default is given."""
    meta = {
        "doc": doc,
        "unit": unit,
        "choices": choices,
        "minimum": minimum,
        "maximum": maximum,
        "positive": positive,
    }
    if default_factory is not REQUIRED:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _is_table(tp: Any) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def _unwrap_optional(tp: Any) -> tuple[Any, bool]:
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return tp, False


def _type_name(tp: Any) -> str:
    inner, optional = _unwrap_optional(tp)
    if _is_table(inner):
        return "table"
    name = {float: "number", int: "integer", str: "string", bool: "boolean"}.get(inner)
    if name is None:
        origin = typing.get_origin(inner)
        name = "table" if origin is dict or inner is dict else str(inner)
    return name


def _convert(value: Any, tp: Any, key: str, meta: dict[str, Any]) -> Any:
    inner, optional = _unwrap_optional(tp)
    if value is None and optional:
        return None
    if inner is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"key '{key}' must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(f"key '{key}' must be finite, got {value}")
    elif inner is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"key '{key}' must be an integer, got {value!r}")
    elif inner is str:
        if not isinstance(value, str):
            raise ConfigError(f"key '{key}' must be a string, got {value!r}")
    elif inner is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"key '{key}' must be true or false, got {value!r}")
    elif typing.get_origin(inner) is dict or inner is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"key '{key}' must be a table")
        return dict(value)
    choices = meta.get("choices")
    if choices is not None and value not in choices:
        raise ConfigError(
            f"key '{key}' must be one of {', '.join(repr(c) for c in choices)}; got {value!r}"
        )
    lo, hi = meta.get("minimum"), meta.get("maximum")
    if lo is not None and value < lo:
        raise ConfigError(f"key '{key}' must be >= {lo:g}, got {value!r}")
    if hi is not None and value > hi:
        raise ConfigError(f"key '{key}' must be <= {hi:g}, got {value!r}")
    if meta.get("positive") and not value > 0:
        raise ConfigError(f"key '{key}' must be > 0, got {value!r}")
    return value


def _fields(cls: type) -> tuple[dict[str, dataclasses.Field], dict[str, Any]]:
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    hints = typing.get_type_hints(cls)
    return fields, hints


def _joined(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def parse_table(cls: type, data: Any, prefix: str = "", skip: tuple[str, ...] = ()) -> Any:
    """Build the dataclass ``cls`` from the TOML table ``data`` at key path ``prefix``.

    Keys listed in ``skip`` are left for the caller (they must be fields of
    ``cls`` holding a table, parsed separately).
    """
    where = f"[{prefix}]" if prefix else "the top level"
    if not isinstance(data, dict):
        raise ConfigError(f"'{prefix}' must be a table")
    fields, hints = _fields(cls)
    for name in data:
        if name not in fields:
            close = difflib.get_close_matches(name, list(fields), n=1)
            hint = f" (did you mean '{_joined(prefix, close[0])}'?)" if close else ""
            raise ConfigError(f"unknown key '{_joined(prefix, name)}' in {where}{hint}")
    values: dict[str, Any] = {}
    for name, f in fields.items():
        key = _joined(prefix, name)
        tp = hints[name]
        inner, _ = _unwrap_optional(tp)
        if name in skip:
            continue
        if name not in data:
            if f.default is REQUIRED and f.default_factory is REQUIRED:
                raise ConfigError(f"missing required key '{key}' in {where}")
            continue
        if _is_table(inner):
            values[name] = parse_table(inner, data[name], key)
        else:
            values[name] = _convert(data[name], tp, key, dict(f.metadata))
    try:
        return cls(**values)
    except (ValueError, TypeError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"{where}: {exc}") from None


def describe(cls: type, prefix: str = "") -> list[dict[str, Any]]:
    """Every key of ``cls`` (recursively): ``key``, ``type``, ``default``, ``unit``, ``doc``, ``required``."""
    out: list[dict[str, Any]] = []
    fields, hints = _fields(cls)
    for name, f in fields.items():
        key = _joined(prefix, name)
        inner, _ = _unwrap_optional(hints[name])
        if _is_table(inner):
            out.extend(describe(inner, key))
            continue
        required = f.default is REQUIRED and f.default_factory is REQUIRED
        default = None if required else (f.default if f.default is not REQUIRED else f.default_factory())
        out.append({
            "key": key,
            "type": _type_name(hints[name]),
            "default": default,
            "required": required,
            "unit": f.metadata.get("unit", ""),
            "choices": f.metadata.get("choices"),
            "doc": f.metadata.get("doc", ""),
        })
    return out


def as_dict(obj: Any) -> dict[str, Any]:
    """A configuration dataclass as a plain, TOML/JSON-friendly dictionary (``None`` dropped)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(obj):
        if not f.init:  # bookkeeping such as RigConfig.source, not a key
            continue
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out[f.name] = as_dict(value)
        elif isinstance(value, dict):
            out[f.name] = {k: as_dict(v) if dataclasses.is_dataclass(v) else v for k, v in value.items()}
        elif isinstance(value, tuple):
            out[f.name] = list(value)
        elif value is not None:
            out[f.name] = value
    return out
