"""The ``modbus`` backend: a Modbus instrument over TCP, RTU over TCP, or RTU on a serial line (pymodbus).

* :mod:`~drivers.modbus.config` -- its ``[modbus]`` table;
* :mod:`~drivers.modbus.registers` -- the register map and its codec;
* :mod:`~drivers.modbus.replies` -- every reply checked against its request;
* :mod:`~drivers.modbus.errors` -- exception responses as named errors;
* :mod:`~drivers.modbus.backend` -- the link, the heater and the PSD (imports pymodbus).
"""

from ..backends import Backend
from .config import ModbusConfig

BACKEND = Backend(
    "modbus", "modbus", ModbusConfig, "drivers.modbus.backend",
    "a Modbus instrument: TCP, RTU over TCP, or RTU on a serial line (pymodbus)",
    "[modbus] required when driver = 'modbus'",
)
