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

import click

from drivers.errors import CodecError, ConfigError, DriverError, InstrumentBusy, LimitError, ServeError
from identify.errors import IdentifyError
from rig.acquisition.errors import AcquisitionError
from sessions.errors import DataFileError, StorageError

#: Exceptions meaning "what the user gave cannot be used" (exit 2).
USER_ERRORS: tuple[type[BaseException], ...] = (
    IdentifyError,
    DataFileError,
    ConfigError,
    LimitError,
    CodecError,
    ServeError,
    AcquisitionError,
    InstrumentBusy,
)

#: Exceptions meaning "the rig failed while being driven" (exit 3): the instrument, its link, or the
#: storage the session is written to (disk full, I/O error, the file removed underneath).
RIG_FAULTS: tuple[type[BaseException], ...] = (DriverError, StorageError)

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
