"""Modbus exception responses as named errors (Modbus Application Protocol v1.1b3, section 7)."""

from __future__ import annotations

import logging

from ..errors import DeviceError, SetpointRefused


def quiet_pymodbus() -> None:
    """Give pymodbus's logger a NullHandler: its messages reach an application's own logging
    configuration, never stderr by default (we report failures ourselves, once)."""
    logger = logging.getLogger("pymodbus")
    if not any(isinstance(h, logging.NullHandler) for h in logger.handlers):
        logger.addHandler(logging.NullHandler())


class ModbusExceptionResponse(DeviceError):
    """The instrument answered with a Modbus exception code (``code``)."""

    code: int = 0
    meaning: str = "unknown exception code"

    def __init__(self, message: str, code: int | None = None) -> None:
        super().__init__(message)
        if code is not None:
            self.code = code


class IllegalFunction(ModbusExceptionResponse):
    code, meaning = 1, "illegal function: the instrument does not support this request"


class IllegalDataAddress(ModbusExceptionResponse):
    code, meaning = 2, "illegal data address: check the register map in rig.toml"


class IllegalDataValue(ModbusExceptionResponse, SetpointRefused):
    code, meaning = 3, "illegal data value: the instrument refused the value"


class DeviceFailure(ModbusExceptionResponse):
    code, meaning = 4, "server device failure"


class Acknowledge(ModbusExceptionResponse):
    code, meaning = 5, "acknowledge: request accepted, still being processed"


class DeviceBusy(ModbusExceptionResponse):
    code, meaning = 6, "server device busy"


class NegativeAcknowledge(ModbusExceptionResponse):
    code, meaning = 7, "negative acknowledge"


class MemoryParityError(ModbusExceptionResponse):
    code, meaning = 8, "memory parity error"


class GatewayPathUnavailable(ModbusExceptionResponse):
    code, meaning = 10, "gateway path unavailable"


class GatewayTargetFailed(ModbusExceptionResponse):
    code, meaning = 11, "gateway target device failed to respond (check unit_id)"


EXCEPTION_CLASSES: dict[int, type[ModbusExceptionResponse]] = {
    cls.code: cls
    for cls in (
        IllegalFunction, IllegalDataAddress, IllegalDataValue, DeviceFailure, Acknowledge,
        DeviceBusy, NegativeAcknowledge, MemoryParityError, GatewayPathUnavailable, GatewayTargetFailed,
    )
}

#: Exception codes after which repeating the request is safe and may succeed.
TRANSIENT_CODES = frozenset({5, 6})


def exception_response(code: int, what: str) -> ModbusExceptionResponse:
    """The named error for exception ``code`` during ``what``."""
    cls = EXCEPTION_CLASSES.get(code, ModbusExceptionResponse)
    return cls(f"{what}: Modbus exception {code} ({cls.meaning})", code)
