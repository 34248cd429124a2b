"""What the commands accept from a recorded run: the partial-session rule and the choice of model.

* A **partial** session (status not ``complete``, or fewer samples than
  planned: being recorded, crashed, aborted, failed) is refused unless the
  command was given ``--partial``: a model or a score computed from an
  unfinished run should be asked for, not happen by accident.
* A **model** is chosen by name; without a name, the most recently stored
  one (commands print which).
* A **run** as the effects and the diagnosis see it (:func:`run_of`): every
  applied point with its time stamp and dwell.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from identify.runs import Run
from sessions import ModelRecord, Session, Status
from sessions.recording import Recording, load_recording

from .errors import UserError


def partial_state(session: Session) -> str:
    """``status aborted, 8 of 12 points applied`` (and, when running, whether anyone is writing it)."""
    text = f"status {session.status.value}, {session.n_samples} of {session.excitation.n_points} points applied"
    if session.status is Status.RUNNING:
        text += ", being recorded now" if session.writer_alive() else ", its writer stopped without finishing it"
    return text


def open_run(path: str | os.PathLike, *, allow_partial: bool) -> Recording:
    """The run at ``path`` (session or CSV trace); a partial session only with ``allow_partial``.

    Empty sessions and sessions without a measured point are refused by
    :func:`sessions.recording.load_recording`.
    """
    data = load_recording(path)
    s = data.session
    if s is not None and s.is_partial and not allow_partial:
        raise UserError(
            f"{path}: the session is partial ({partial_state(s)}); add --partial to use the points it holds"
        )
    return data


def choose_model(session: Session, name: str | None) -> ModelRecord:
    """The model stored as ``name`` in ``session``, or (no name) the most recently stored one."""
    path = session.path
    if not session.models:
        raise UserError(f"{path}: holds no model; identify one first (rig identify {path})")
    if name is None:
        return max(session.models.values(), key=lambda m: (m.created_at, m.name))
    if name not in session.models:
        raise UserError(f"{path}: holds no model named {name!r} (it holds: {', '.join(sorted(session.models))})")
    return session.models[name]


def session_of(data: Recording, what: str) -> Session:
    """``data``'s session, or a one-line error saying that ``what`` needs one."""
    if data.session is None:
        raise UserError(f"{data.path}: is a CSV trace; {what} needs a session (rig import it first)")
    return data.session


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name the same file."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def run_of(data: Recording, name: str | None = None, rows: np.ndarray | None = None) -> Run:
    """A :class:`Run` from a recording: a session's time stamps and dwells, or a CSV trace's times,
    in the recording's units; ``rows`` (measured rows kept, default all) leaves the others unmeasured.
    ``name`` defaults to the file's stem (per-run effects of a stored model are kept under it)."""
    name = data.path.stem if name is None else name
    s = data.session
    units = {"input_unit": data.input_unit, "output_unit": data.output_unit, "by_curves": data.curves is not None}
    outputs = data.outputs if s is None else s.outputs
    if rows is not None:
        kept = np.full(outputs.shape, np.nan)
        kept[rows] = outputs[rows]
        outputs = kept
    if s is None:
        dwell = data.dwell_s if data.dwell_s is not None else np.full(data.inputs.size, np.nan)
        return Run(name, data.inputs, outputs, data.t_s, dwell, **units)
    readings = s.excitation.dwell.get("readings")
    return Run(name, s.inputs, outputs, s.t_s, s.samples["dwell_s"],
               int(readings) if isinstance(readings, (int, float)) else None, **units)
