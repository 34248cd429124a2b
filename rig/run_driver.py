"""A run on the rig from the command line: progress bar, Ctrl-C, faults, the heater's state and exit codes.

Shared by ``rig acquire`` and ``rig track``, which differ only in what they
run.  :func:`drive` opens the rig, runs, and ends in one of these ways:

* complete, heater confirmed at 0 V: the caller reports (exit 0);
* aborted (Ctrl-C, SIGTERM): the summary, then one line with the heater's
  state and how to continue, exit 130;
* a driver or storage fault: one line naming the heater's state, the
  session and how to continue (``resume_command``), exit 3;
* complete but the heater not confirmed at 0 V: exit 3, saying so.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import click

from drivers.config import RigConfig, load_config, parse_config
from drivers.errors import CodecError, ConfigError, DriverError, LimitError, SafeStateError, SetpointRefused
from drivers.protocols import SafeState
from drivers.rig import Rig, open_rig
from rig.acquisition import AcquisitionError, Hooks, PauseSwitch, RunOutcome
from rig.acquisition.progress import ProgressBar, terminal_prompt
from sessions import DataFileError, Session, Status, StorageError, read_session

from .errors import RigFault

#: Exit code of a run aborted by the operator (as for Ctrl-C everywhere in ``rig``).
EXIT_ABORTED = 130


def config_for_resume(config_path: Path | None, session: Session) -> RigConfig:
    """The rig to resume ``session`` on: ``--config``, else the configuration stored in the session."""
    if config_path is not None:
        return load_config(config_path)
    if not session.rig_config:
        raise AcquisitionError(f"{session.path}: no rig configuration stored; give --config")
    try:
        return parse_config(session.rig_config, f"{session.path} (stored rig configuration)")
    except ConfigError as exc:
        raise ConfigError(f"{exc}; give --config") from None


def drive(cfg: RigConfig, target: Path, total: int, start: int, progress: bool | None,
          run: Callable[[Rig, Hooks], RunOutcome], report: Callable[[RunOutcome], None],
          resume_command: str) -> RunOutcome:
    """Open the rig of ``cfg`` and ``run`` on it into the session ``target`` (``total`` points, ``start`` of
    them recorded before); ``report(outcome)`` prints the summary.  ``resume_command`` (``rig acquire``)
    is what the messages advise to continue with."""
    bar = ProgressBar(total, start, enabled=sys.stderr.isatty() if progress is None else progress)
    switch = PauseSwitch()
    hooks = Hooks(switch, terminal_prompt(bar), bar.update)
    rig = None
    try:
        with switch.installed(linger=True), open_rig(cfg) as rig:
            outcome = run(rig, hooks)
    except (DriverError, StorageError) as exc:
        bar.close()
        if rig is None or rig.heater_state is None or not target.exists():
            raise  # nothing was driven, or the session was never created: the error says it all
        after = after_fault(target, rig.heater_state, resume_command, exc)
        raise RigFault(after if isinstance(exc, SafeStateError) else f"{exc} -- {after}") from None
    except KeyboardInterrupt as exc:  # an abort outside the run itself (opening the rig, closing it)
        bar.close()
        heater = rig.heater_state if rig is not None else None
        said = heater.describe() if heater is not None else "the heater was not driven"
        kept = ""
        if target.exists() and rig is not None:
            s = read_session(target)
            kept = f"; session {target} is {s.status.value} with {s.n_samples} of {s.excitation.n_points} points kept"
        click.echo(f"aborted ({str(exc) or 'interrupted'}): {said}{kept}", err=True)
        raise click.exceptions.Exit(EXIT_ABORTED) from None
    bar.close()
    report(outcome)
    if outcome.status is Status.ABORTED:
        click.echo(
            f"aborted ({outcome.message}): {rig.heater_state.describe()}; every sample kept; "
            f"{resume_advice(target, rig.heater_state, resume_command)}", err=True,
        )
        raise click.exceptions.Exit(EXIT_ABORTED)
    if not rig.heater_state.confirmed:  # complete, but the heater could not be confirmed at 0 V
        raise RigFault(after_fault(target, rig.heater_state, resume_command))
    return outcome


def resume_advice(target: Path, heater: SafeState, resume_command: str, fault: BaseException | None = None) -> str:
    """How to continue an interrupted run, given what is known about the heater and what stopped it."""
    if isinstance(fault, (SetpointRefused, LimitError, CodecError)):
        return ("the plan cannot be completed on this rig as configured (--resume would fail the same way): "
                "fix [heater] in rig.toml (max_V, max_current_mA, full_scale_V) or the plan, and start a new run")
    if not heater.confirmed:
        return f"once the bench is safe and the instrument answers, continue with: {resume_command} --resume {target}"
    if isinstance(fault, StorageError):
        return f"free space (or mend the disk), then continue with: {resume_command} --resume {target}"
    return f"continue with: {resume_command} --resume {target}"


def after_fault(target: Path, heater: SafeState, resume_command: str, fault: BaseException | None = None) -> str:
    """What a fault left behind, in one clause: the heater as known, the session, and what to do."""
    try:
        s = read_session(target)
    except DataFileError as exc:
        return f"{heater.describe()}; the session cannot be read back ({exc})"
    kept = f"session {target} is {s.status.value} with {s.n_samples} of {s.excitation.n_points} points kept"
    if s.status is Status.COMPLETE:
        return f"{heater.describe()}; {kept}"
    return f"{heater.describe()}; {kept}; {resume_advice(target, heater, resume_command, fault)}"
