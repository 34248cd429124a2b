"""A misbehaving Modbus TCP gateway for the fault tests: a real asyncio proxy on loopback, on its own thread,
between ``rig acquire`` and ``rig serve-sim``.

Every request is forwarded to the server and every reply passed back, except where a :class:`Fault` says
otherwise: a fault matches requests of one kind (``psd``: a read of input register 0, the PSD;
``readback``: a read of holding register 0, the set-point; ``write``: a write of the set-point), skips the
first ``after`` of them and then misbehaves on ``count`` of them (``None``: on every one from then on):

* ``wrong_function`` -- the reply is an FC 3 frame carrying another value (``value`` volts more);
* ``byte_count`` -- the reply's byte count says 4 but six data bytes follow (the frame length is consistent);
* ``wrong_unit`` / ``wrong_tid`` -- the reply names another unit id / transaction id;
* ``stale`` -- the reply is the previous reply of that kind again (with the current transaction id);
* ``constant`` -- the reply carries ``value`` (float32), whatever the sensor says;
* ``nan`` / ``saturated`` -- the reply carries NaN / ``value`` (default 10.5 V, beyond the PSD's rail);
* ``drop_write`` -- a write is acknowledged (its echo is sent back) but never reaches the instrument;
* ``slow`` -- the reply is sent after ``value`` seconds;
* ``truncated`` -- only the first half of the reply is sent (and nothing more for that request).

Bounded: the proxy's sockets time out with the tests' processes, and :meth:`ModbusProxy.close` stops the
loop and joins the thread within seconds.  Only loopback addresses are used.
"""

from __future__ import annotations

import asyncio
import math
import struct
import threading
from dataclasses import dataclass, field

#: Modbus function codes the rig uses.
READ_HOLDING, READ_INPUT, WRITE_MULTIPLE = 3, 4, 16

KINDS = ("psd", "readback", "write")
MODES = ("wrong_function", "byte_count", "wrong_unit", "wrong_tid", "stale", "constant", "nan", "saturated",
         "drop_write", "slow", "truncated")


@dataclass
class Fault:
    """Misbehave on requests of ``kind``: skip ``after`` of them, then ``count`` (None: all the rest)."""

    mode: str
    kind: str = "psd"
    after: int = 0
    count: int | None = 1
    value: float | None = None
    seen: int = 0
    applied: int = 0

    def __post_init__(self) -> None:
        assert self.mode in MODES and self.kind in KINDS, (self.mode, self.kind)

    def matches(self) -> bool:
        """Count one request of this kind; whether this one misbehaves."""
        k = self.seen
        self.seen += 1
        hit = k >= self.after and (self.count is None or k < self.after + self.count)
        self.applied += hit
        return hit


def _kind(fc: int, pdu: bytes) -> str | None:
    address = struct.unpack(">H", pdu[1:3])[0] if len(pdu) >= 3 else -1
    if fc == READ_INPUT and address == 0:
        return "psd"
    if fc == READ_HOLDING and address == 0:
        return "readback"
    if fc == WRITE_MULTIPLE and address == 0:
        return "write"
    return None


def _frame(tid: int, unit: int, pdu: bytes) -> bytes:
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def _f32(volts: float) -> bytes:
    return struct.pack(">f", volts)


@dataclass
class _Conn:
    last: dict[str, bytes] = field(default_factory=dict)  # the last true reply PDU of each kind


class ModbusProxy:
    """``with ModbusProxy(upstream_port) as proxy:`` -- listens on 127.0.0.1:``proxy.port``."""

    def __init__(self, upstream_port: int, faults: list[Fault] | None = None) -> None:
        self.upstream_port = upstream_port
        self.faults: list[Fault] = list(faults or [])
        self._lock = threading.Lock()
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._main, name="modbus-proxy", daemon=True)
        self._thread.start()
        if not self._ready.wait(10):
            raise AssertionError("the Modbus proxy did not start")

    # ------------------------------------------------------------ control
    def add(self, fault: Fault) -> Fault:
        with self._lock:
            self.faults.append(fault)
        return fault

    def close(self) -> None:
        if self._loop.is_running():
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(10)

    def __enter__(self) -> "ModbusProxy":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ the loop
    def _main(self) -> None:
        asyncio.set_event_loop(self._loop)
        self._loop.run_until_complete(self._serve())
        self._loop.close()

    async def _serve(self) -> None:
        self._stop = asyncio.Event()
        server = await asyncio.start_server(self._client, "127.0.0.1", 0)
        self.port = server.sockets[0].getsockname()[1]
        self._ready.set()
        async with server:
            await self._stop.wait()
            server.close()

    def _fault_for(self, kind: str | None) -> Fault | None:
        if kind is None:
            return None
        with self._lock:
            hit = None
            for f in self.faults:
                if f.kind == kind and f.matches() and hit is None:
                    hit = f
            return hit

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        conn = _Conn()
        try:
            up_r, up_w = await asyncio.wait_for(asyncio.open_connection("127.0.0.1", self.upstream_port), 5)
        except (OSError, asyncio.TimeoutError):
            writer.close()
            return
        try:
            while not self._stop.is_set():
                head = await reader.readexactly(7)
                tid, _, length, unit = struct.unpack(">HHHB", head)
                pdu = await reader.readexactly(length - 1)
                fc = pdu[0]
                kind = _kind(fc, pdu)
                fault = self._fault_for(kind)
                if fault is not None and fault.mode == "drop_write":
                    writer.write(_frame(tid, unit, pdu[:5]))  # the echo of address and count: "done"
                    await writer.drain()
                    continue
                up_w.write(head + pdu)
                await up_w.drain()
                rhead = await asyncio.wait_for(up_r.readexactly(7), 5)
                rtid, _, rlength, runit = struct.unpack(">HHHB", rhead)
                reply = await asyncio.wait_for(up_r.readexactly(rlength - 1), 5)
                true_reply = reply
                out_tid, out_unit = rtid, runit
                if fault is not None:
                    reply, out_tid, out_unit = self._misbehave(fault, conn, kind, reply, rtid, runit)
                    if fault.mode == "slow":
                        await asyncio.sleep(fault.value or 1.0)
                if kind is not None and true_reply[0] == fc:
                    conn.last[kind] = true_reply
                frame = _frame(out_tid, out_unit, reply)
                if fault is not None and fault.mode == "truncated":
                    frame = frame[: len(frame) // 2]
                writer.write(frame)
                await writer.drain()
        except (asyncio.IncompleteReadError, ConnectionError, asyncio.TimeoutError, OSError):
            pass
        finally:
            for w in (writer, up_w):
                w.close()

    @staticmethod
    def _misbehave(fault: Fault, conn: _Conn, kind: str, reply: bytes, tid: int, unit: int) -> tuple[bytes, int, int]:
        mode = fault.mode
        true_volts = struct.unpack(">f", reply[2:6])[0] if len(reply) >= 6 and reply[0] < 0x80 else math.nan
        if mode == "wrong_function":
            return bytes([READ_HOLDING, 4]) + _f32(true_volts + (fault.value or 4.0)), tid, unit
        if mode == "byte_count":
            return bytes([reply[0], 4]) + reply[2:6] + b"\x00\x00", tid, unit
        if mode == "wrong_unit":
            return reply, tid, (unit + 1) % 256
        if mode == "wrong_tid":
            return reply, (tid + 7) % 65536, unit
        if mode == "stale":
            return conn.last.get(kind, reply), tid, unit
        if mode == "constant":
            return bytes([reply[0], 4]) + _f32(fault.value or 0.0), tid, unit
        if mode == "nan":
            return bytes([reply[0], 4]) + _f32(math.nan), tid, unit
        if mode == "saturated":
            return bytes([reply[0], 4]) + _f32(fault.value or 10.5), tid, unit
        return reply, tid, unit  # slow, truncated: the true reply, late or cut
