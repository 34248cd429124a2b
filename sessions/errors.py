"""Errors about data files (CSV traces, sessions): shown to the user as one line."""


class DataFileError(ValueError):
    """A data file is missing, malformed, or not what was expected."""


class StorageError(OSError):
    """The session could not be written: disk full, an I/O error, the file removed underneath.

    Not the user's input (exit 3, as for a fault of the rig): the file system
    failed while the program was writing.  The message says what was kept.
    """
