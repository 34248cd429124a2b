"""Every Modbus reply is checked against the request it answers before its registers are believed.

pymodbus matches a reply to its request by transaction and unit id, but
decodes whatever function code arrives: a gateway answering a read of
input registers (FC 4) with a holding-register frame (FC 3) was recorded as
a normal sample.  :func:`reply_mismatch` compares, for every reply,

* the function code with the request's (an exception reply must name the
  request's function code too);
* the unit id and the transaction id with the request's;
* for a register read, the byte count with twice the registers asked for
  and with the data bytes the frame really carries (:data:`STRICT_READS`
  keep both numbers while decoding);
* for a write, the echoed address and register count.

A mismatch is a failed request: the link closes it (a stray frame must not
answer the next request) and retries it like a garbage reply.
"""

from __future__ import annotations

from typing import Any

from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadHoldingRegistersResponse,
    ReadInputRegistersRequest,
    ReadInputRegistersResponse,
    WriteMultipleRegistersRequest,
)


class _Counted:
    """A register-read response that keeps the byte count it announced and the data bytes it carried."""

    byte_count: int | None = None
    data_bytes: int | None = None

    def decode(self, data: bytes) -> None:
        self.byte_count = int(data[0]) if data else None
        self.data_bytes = len(data) - 1
        super().decode(data)  # type: ignore[misc]


class CheckedHoldingReply(_Counted, ReadHoldingRegistersResponse):
    """FC 3 reply, byte count kept."""


class CheckedInputReply(_Counted, ReadInputRegistersResponse):
    """FC 4 reply, byte count kept."""


#: The response classes a client registers (``client.register``) so that reads can be checked.
STRICT_READS = (CheckedHoldingReply, CheckedInputReply)


def read_request(table: str, address: int, count: int, unit: int) -> ModbusPDU:
    """The PDU reading ``count`` registers of ``table`` (``holding`` or ``input``) at ``address``."""
    cls = ReadHoldingRegistersRequest if table == "holding" else ReadInputRegistersRequest
    return cls(address=address, count=count, dev_id=unit)


def write_request(address: int, words: list[int], unit: int) -> ModbusPDU:
    """The PDU writing ``words`` from ``address`` (FC 16, one request for the whole value)."""
    return WriteMultipleRegistersRequest(address=address, registers=words, dev_id=unit)


def reply_mismatch(request: ModbusPDU, response: Any) -> str | None:
    """What makes ``response`` not the answer to ``request`` (one clause), or None when it is."""
    fc = request.function_code
    if not isinstance(response, ModbusPDU):
        return f"no Modbus reply ({type(response).__name__})"
    got = response.function_code
    if isinstance(response, ExceptionResponse):
        if got & 0x7F != fc:
            return f"an exception reply for function code {got & 0x7F} to a request with function code {fc}"
    elif got != fc:
        return f"a reply with function code {got} to a request with function code {fc}"
    if response.dev_id != request.dev_id:
        return f"a reply from unit {response.dev_id} to a request to unit {request.dev_id}"
    if response.transaction_id != request.transaction_id:
        return f"a reply to transaction {response.transaction_id} for transaction {request.transaction_id}"
    if isinstance(response, ExceptionResponse):
        return None
    if fc in (3, 4):
        want = 2 * request.count
        count = getattr(response, "byte_count", None)
        if count != want or getattr(response, "data_bytes", want) != want:
            return (f"a reply announcing {count} data bytes and carrying {getattr(response, 'data_bytes', '?')} "
                    f"for {request.count} register(s) ({want} bytes)")
    elif fc == 16:
        if (response.address, response.count) != (request.address, request.count):
            return (f"a write acknowledged for {response.count} register(s) at {response.address} instead of "
                    f"{request.count} at {request.address}")
    return None
