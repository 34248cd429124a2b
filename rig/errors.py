"""How errors reach the user: always one line, with an exit code that says whose problem it is.

* Exit 2 -- **bad input**: what the user gave cannot be used (data files,
  arguments, ``rig.toml``, a set-point beyond the limits).  Every package
  raises its own error type for these; they are listed once in
  :data:`USER_ERRORS`.
* Exit 3 -- **rig fault**: the instrument or its link failed while being
  driven (no connection, timeout, garbage or error replies, unusable PSD
  readings).  The command was fine; the bench needs attention.  The heater
  is at 0 V whenever one of these escapes (see :mod:`drivers.rig`).
* Exit 1 -- anything else is a bug in this program (see :mod:`rig.cli`).
"""

from __future__ import annotations

import sys

import click

#: Exceptions meaning "what the user gave cannot be used" (exit 2), as (module, class name).
USER_ERRORS: tuple[tuple[str, str], ...] = (
    ("identify.errors", "IdentifyError"),
    ("sessions.errors", "DataFileError"),
    ("drivers.errors", "ConfigError"),
    ("drivers.errors", "LimitError"),
    ("drivers.errors", "CodecError"),
    ("drivers.errors", "ServeError"),
    ("rig.acquisition.errors", "AcquisitionError"),
    ("drivers.errors", "InstrumentBusy"),
    ("rig.parallel", "SchedulerError"),
)

#: Exceptions meaning "the rig failed while being driven" (exit 3), as (module, class name): the
#: instrument, its link, or the storage the session is written to (disk full, I/O error, the file removed).
RIG_FAULTS: tuple[tuple[str, str], ...] = (("drivers.errors", "DriverError"), ("sessions.errors", "StorageError"))


def _loaded(kinds: tuple[tuple[str, str], ...]) -> tuple[type[BaseException], ...]:
    """The classes of ``kinds`` whose modules are imported.

    An exception can only be an instance of a class whose module has been
    imported, so this never needs to import one: the ``rig`` command starts
    without importing the drivers (pymodbus), the sessions (h5py) or the
    numerics just to be able to name their errors.
    """
    found = []
    for module, name in kinds:
        mod = sys.modules.get(module)
        if mod is not None:
            found.append(getattr(mod, name))
    return tuple(found)


def is_user_error(exc: BaseException) -> bool:
    """Whether ``exc`` is one of :data:`USER_ERRORS` (bad input: exit 2)."""
    return isinstance(exc, _loaded(USER_ERRORS))


def is_rig_fault(exc: BaseException) -> bool:
    """Whether ``exc`` is one of :data:`RIG_FAULTS` (the instrument or its link: exit 3)."""
    return isinstance(exc, _loaded(RIG_FAULTS))


#: Exit code for bad input (as click uses for usage errors).
EXIT_BAD_INPUT = 2
#: Exit code for an instrument or connection fault.
EXIT_RIG_FAULT = 3


class UserError(click.ClickException):
    """A one-line error about the user's input; exit code 2."""

    exit_code = EXIT_BAD_INPUT

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


class RigFault(UserError):
    """A one-line error about the instrument or its link; exit code 3."""

    exit_code = EXIT_RIG_FAULT
