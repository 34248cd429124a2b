"""Printing results: JSON on stdout for scripts, aligned tables for people."""

from __future__ import annotations

import json
import math
from typing import Any, Sequence

import click
import numpy as np


def jsonable(obj: Any) -> Any:
    """Convert numpy scalars/arrays and non-finite floats (-> null) for JSON."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    return obj


def print_json(obj: Any) -> None:
    """One JSON object on stdout."""
    click.echo(json.dumps(jsonable(obj), allow_nan=False))


def format_table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A plain aligned text table (numbers right-aligned)."""

    def cell(v: Any) -> str:
        if isinstance(v, (float, np.floating)):
            return "-" if not math.isfinite(v) else f"{v:.4g}"
        return str(v)

    text = [[cell(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in text)) if text else len(h) for i, h in enumerate(headers)]
    numeric = [all(isinstance(r[i], (int, float, np.number)) for r in rows) for i in range(len(headers))]

    def line(vals: Sequence[str]) -> str:
        return "  ".join(v.rjust(w) if num else v.ljust(w) for v, w, num in zip(vals, widths, numeric)).rstrip()

    out = [line(headers), line(["-" * w for w in widths])]
    out.extend(line(r) for r in text)
    return "\n".join(out)


def unit_token(unit: str) -> str:
    """A unit as part of a column or key name: ``um`` -> ``rmse_um``, ``A m^2`` -> ``rmse_Am^2``."""
    return "".join(unit.split()) or "1"


def nrmse_text(value: float) -> str:
    """The normalised RMSE as people read it: ``0.00184 of the output range``.

    One convention everywhere -- tables, JSON (``nrmse``), ``report.md`` and
    figures: a fraction of the output range, never a percent.
    """
    return f"{value:.3g} of the output range" if math.isfinite(value) else "- (no output range)"
