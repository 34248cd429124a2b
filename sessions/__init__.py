"""Recorded data: CSV traces and HDF5 acquisition sessions.

* :mod:`sessions.csvtrace` -- the CSV trace ``t_s,v_V,deflection_um``;
* :mod:`sessions.schema` -- the session layout (documented in ``docs/sessions.md``);
* :mod:`sessions.writer` -- :class:`SessionWriter`, one sample at a time, crash-safe;
* :mod:`sessions.reader` -- :func:`read_session` and :class:`SessionFollower` (live);
* :mod:`sessions.rewrite` -- changing an existing session (adding a model) atomically;
* :mod:`sessions.models` -- identified models stored under ``/models/<name>``;
* :mod:`sessions.convert` -- CSV traces to sessions and back;
* :mod:`sessions.targets` -- target files ``t_s,target_um`` and ``rig invert``'s set-point files.
"""

from .csvtrace import HEADER, Trace, read_trace, write_trace
from .errors import DataFileError, StorageError
from .models import ModelRecord
from .reader import Session, SessionFollower, is_hdf5, read_session
from .records import Event, ExcitationRecord, IdentifyRecipe, Quantities
from .rewrite import add_model
from .schema import ADAPTIVE_COLUMNS, ADAPTIVE_KIND, SCHEMA_VERSION, TRACKING_COLUMNS, SampleFlag, Status
from .writer import SessionWriter

__all__ = [
    "HEADER",
    "SCHEMA_VERSION",
    "TRACKING_COLUMNS",
    "ADAPTIVE_COLUMNS",
    "ADAPTIVE_KIND",
    "DataFileError",
    "Event",
    "ExcitationRecord",
    "IdentifyRecipe",
    "ModelRecord",
    "Quantities",
    "SampleFlag",
    "Session",
    "SessionFollower",
    "SessionWriter",
    "Status",
    "StorageError",
    "Trace",
    "add_model",
    "is_hdf5",
    "read_session",
    "read_trace",
    "write_trace",
]
