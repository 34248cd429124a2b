"""A run from start to end: session, saturation, (replay,) points, final status -- and the heater at 0 V.

:func:`acquire` starts a new session; :func:`resume` continues an
interrupted one.  Both end the same way:

* **complete** -- every planned point recorded; heater to 0 V;
* **aborted** -- Ctrl-C twice, or abort chosen at the pause prompt, or
  SIGTERM: heater to 0 V first, then the session is marked ``aborted``
  with every sample kept; returned (not raised) so the caller can report;
* **failed** -- any other exception (a driver fault, a full disk): heater
  to 0 V first, the session marked ``failed`` with the error, every
  sample kept; the exception is re-raised.

"Heater to 0 V" is :meth:`drivers.rig.Rig.safe_state`: the log message of
the final status says what is *known* -- 0 V acknowledged and read back,
or that the heater state is unknown and why -- and so does
:attr:`RunOutcome.heater` (and :attr:`Rig.heater_state` when an exception
is raised).

**Resuming** (:func:`resume`) restores the memory state before going on,
because hysteresis has memory: opening the rig already wrote 0 V, so the
device is not where the interrupted run left it.  The sequencer drives to
negative saturation (0 V for a full dwell), replays the recorded inputs of
every completed point without measuring (a full dwell at reversal points
and at the last completed point, a transit elsewhere: the same rule as
compressive acquisition), logs ``replayed``, and continues with the next
point, flagged ``AFTER_RESUME``.  No point is recorded twice or skipped:
the writer's count is the next point.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drivers.protocols import SafeState
from drivers.rig import Rig
from sessions import (DataFileError, ExcitationRecord, IdentifyRecipe, ModelRecord, SampleFlag, Session, SessionWriter,
                      Status, read_session)

from .dwell import DwellSettings
from .engine import PointResult, Sequencer
from .errors import AcquisitionError
from .interrupt import Decision, PauseInfo, PauseSwitch
from .plan import AcquisitionPlan
from .setpoint_source import SetpointSource


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended.  ``start`` samples were in the session before it (0 for a new one),
    ``replayed`` of them were re-applied to restore the memory state; ``wall_s`` in s;
    ``heater`` what is known about the heater at the end."""

    path: Path
    status: Status
    start: int
    replayed: int
    message: str
    wall_s: float
    heater: SafeState | None = None


@dataclass
class Hooks:
    """The caller's side of a run: Ctrl-C switch, pause decision, per-sample callback."""

    pause: PauseSwitch | None = None
    on_pause: Callable[[PauseInfo], Decision] | None = None
    on_sample: Callable[[PointResult], None] | None = None


def _drive(rig: Rig, writer: SessionWriter, body: Callable[[], None], start: int, replayed: list[int]) -> RunOutcome:
    t0 = time.perf_counter()

    def outcome(status: Status, message: str, heater: SafeState) -> RunOutcome:
        return RunOutcome(writer.path, status, start, replayed[0], message, time.perf_counter() - t0, heater)

    with writer:
        try:
            body()
        except KeyboardInterrupt as exc:  # Aborted, a second Ctrl-C, SIGTERM
            heater = rig.safe_state()
            message = str(exc) or "interrupted"
            writer.finish(Status.ABORTED, f"{message}; {heater.describe()}")
            return outcome(Status.ABORTED, message, heater)
        except BaseException as exc:
            heater = rig.safe_state()
            writer.finish(Status.FAILED, f"{type(exc).__name__}: {exc}; {heater.describe()}"
                          if heater.confirmed else f"{heater.describe()}; {type(exc).__name__}: {exc}")
            raise
        heater = rig.safe_state()
        writer.finish(Status.COMPLETE, "" if heater.confirmed else heater.describe())
        return outcome(Status.COMPLETE, "", heater)


def acquire(
    rig: Rig,
    record: ExcitationRecord,
    path: str | os.PathLike,
    *,
    settings: DwellSettings | None = None,
    operator: str = "",
    notes: str = "",
    hooks: Hooks | None = None,
    fsync_interval_s: float | None = 1.0,
    setpoints: SetpointSource | None = None,
    sample_columns: np.dtype | None = None,
    models: tuple[ModelRecord, ...] = (),
    recipe: IdentifyRecipe | None = None,
) -> RunOutcome:
    """Run ``record`` (an excitation with its measure plan and dwell settings, see
    :func:`~rig.acquisition.plan.make_record`) on ``rig`` into the new session ``path``.

    ``settings`` defaults to the ones described in ``record.dwell``.
    Raises before creating the session when the plan does not fit the heater.
    A tracking run gives ``setpoints`` (which decides each set-point as it is
    applied), the extra ``sample_columns`` it records and the ``models`` to
    store from the start.  ``recipe`` is recorded as how the session wants to
    be identified (:func:`~rig.acquisition.recipe.default_recipe`).
    """
    plan = AcquisitionPlan.from_record(record)
    plan.check_window(rig.heater.window, rig.heater.check_setpoint)  # as the wire carries them, full scale too
    settings = settings if settings is not None else DwellSettings.from_description(record.dwell)
    plan.check_settings(settings)
    hooks = hooks or Hooks()
    writer = SessionWriter.create(
        path, record, rig_config=rig.config.to_dict(), driver=rig.description,
        operator=operator, notes=notes, fsync_interval_s=fsync_interval_s,
        sample_columns=sample_columns, models=models, recipe=recipe,
    )
    seq = Sequencer(rig.heater, rig.sensor, rig.clock, plan, settings, writer,
                    pause=hooks.pause, on_pause=hooks.on_pause, on_sample=hooks.on_sample, setpoints=setpoints)

    def body() -> None:
        seq.saturate()
        seq.run()

    return _drive(rig, writer, body, 0, [0])


def resumable(path: str | os.PathLike, tracking: bool = False) -> Session:
    """The interrupted session at ``path``, checked for resuming (nothing is written); ``tracking``: by
    ``rig track --resume`` (a tracking run's set-points come from its model and feedback, not its plan)."""
    session = read_session(path)
    if (session.excitation.targets is not None) != tracking:
        if tracking:
            raise AcquisitionError(f"{path}: not a tracking run (no targets); continue it with rig acquire --resume")
        raise AcquisitionError(f"{path}: a tracking run (its set-points follow targets through a model); "
                               f"continue it with rig track --resume {path}")
    if session.status is Status.COMPLETE:
        raise DataFileError(f"{path}: the session is complete; there is nothing to resume")
    if session.n_samples >= session.excitation.n_points:
        raise DataFileError(f"{path}: every planned point is already recorded")
    if session.writer_alive():
        raise DataFileError(f"{path}: another process is writing this session now")
    if session.excitation.dwell.get("policy") in (None, "unknown"):
        raise AcquisitionError(f"{path}: not recorded by 'rig acquire' (no dwell policy); cannot resume it")
    return session


def resume(
    rig: Rig,
    path: str | os.PathLike,
    *,
    hooks: Hooks | None = None,
    fsync_interval_s: float | None = 1.0,
    setpoints: SetpointSource | None = None,
) -> RunOutcome:
    """Continue the interrupted session ``path`` on ``rig``: saturate, replay, go on (see the module doc).

    A tracking run gives its ``setpoints`` (rebuilt from the session, the points recorded so far
    included)."""
    session = resumable(path, tracking=setpoints is not None)
    plan = AcquisitionPlan.from_record(session.excitation)
    plan.check_window(rig.heater.window, rig.heater.check_setpoint)  # as the wire carries them, full scale too
    settings = DwellSettings.from_description(session.excitation.dwell)
    plan.check_settings(settings)
    hooks = hooks or Hooks()
    where = rig.description.get("endpoint") or rig.description.get("driver")
    writer = SessionWriter.reopen(
        path, reason=f"rig acquire --resume at point {session.n_samples} on {rig.config.driver} ({where})",
        fsync_interval_s=fsync_interval_s,
    )
    count = writer.count  # equals session.n_samples: reopen keeps every valid row
    history = session.inputs[:count]
    elapsed = float(session.t_s[count - 1]) if count else 0.0
    seq = Sequencer(rig.heater, rig.sensor, rig.clock, plan, settings, writer,
                    pause=hooks.pause, on_pause=hooks.on_pause, on_sample=hooks.on_sample, setpoints=setpoints)
    replayed = [0]

    def body() -> None:
        seq.saturate()
        rep = seq.replay(history)
        replayed[0] = rep.points
        what = f"replayed points 0..{count - 1} without measuring ({rep.settled} at rest)" if count else "nothing to replay"
        writer.log("replayed", f"memory state restored from negative saturation: {what} in {rep.seconds:.6g} s of rig time")
        seq.run(count, elapsed, first_flags=SampleFlag.AFTER_RESUME)

    return _drive(rig, writer, body, count, replayed)
