"""The ``serial`` backend: an instrument with a line protocol on a serial port (pyserial), SCPI-like by default.

* :mod:`~drivers.serial.config` -- its ``[serial]`` table and command set;
* :mod:`~drivers.serial.backend` -- the link, the heater and the PSD (imports pyserial).
"""

from ..backends import Backend
from .config import SerialConfig

BACKEND = Backend(
    "serial", "serial", SerialConfig, "drivers.serial.backend",
    "an instrument with a line protocol on a serial port (pyserial), SCPI-like by default",
    "[serial] required when driver = 'serial'",
)
