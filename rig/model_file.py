"""A model JSON file: what ``rig identify --json`` and ``--out`` write, and ``rig predict``, ``rig invert`` and
``rig track`` read."""

from __future__ import annotations

import json
from pathlib import Path

from identify import PreisachModel
from identify.model_json import model_from_dict
from sessions.formats import FileKind, detect

from .errors import UserError


def load_model(path: Path) -> PreisachModel:
    """A model from a JSON file written by ``rig identify --json`` or ``--out``."""
    if path.is_file() and detect(path) is FileKind.HDF5:
        raise UserError(f"{path}: an HDF5 file (a session), not a JSON model file; for a model stored in a "
                        f"session use rig validate {path} --check FILE, or write one with rig identify --out")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: cannot read the model ({exc})") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}: not a JSON model (line {exc.lineno}: {exc.msg})") from None
    try:
        return model_from_dict(data)
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None
