"""The simulated device behind the line protocol of the ``serial`` driver.

:class:`LineProtocol` is the instrument's command interpreter (one line in,
at most one line out), SCPI-like and driven by the same
``[serial.commands]`` as the client:

* the set command (``SOUR:VOLT <v>``) applies the voltage, no reply; a
  value that is not a number, not finite or beyond the output's range is
  refused and queued as an error;
* ``SOUR:VOLT?`` -> set-point (V); ``MEAS:DEFL?`` -> PSD voltage (V);
  ``*IDN?`` -> identification; ``SYST:ERR?`` -> oldest queued error, or
  ``0,"No error"``;
* an unknown query is answered ``ERR -113,"Undefined header"``; an unknown
  command is only queued.

It is served on a TCP socket (clients use ``socket://host:port``) or on a
pseudo-terminal (clients open ``/dev/pts/N`` like a real serial port).
"""

from __future__ import annotations

import asyncio
import os
import tty
from collections import deque

from ..serial.config import SerialCommands, parse_leading_number
from .device import DeviceRefused, SimVO2
from .faults import FaultPlan
from .journal import Journal

IDENTITY = "vo2rig,SimVO2,0,1"
GARBAGE = "#?!%~"


class LineProtocol:
    """One simulated instrument's command interpreter."""

    def __init__(self, device: SimVO2, commands: SerialCommands, journal: Journal, faults: FaultPlan) -> None:
        self.device = device
        self.commands = commands
        self.journal = journal
        self.faults = faults
        self.errors: deque[str] = deque(maxlen=32)

    def handle(self, line: str) -> str | None:
        """The reply to one command line (without terminator), or None for no reply."""
        line = line.strip()
        self.journal.line(line)
        c = self.commands
        if not line:
            return None
        if line == c.query_voltage:
            return f"{self.device.applied_voltage:.9g}"
        if line == c.measure_psd:
            return f"{self.device.read_psd():.9g}"
        if line == c.identify:
            return IDENTITY
        if c.error_query and line == c.error_query:
            return self.errors.popleft() if self.errors else '0,"No error"'
        if line.startswith(c.set_prefix):
            self._set(line[len(c.set_prefix):])
            return None
        self.errors.append('-113,"Undefined header"')
        return f'{c.error_prefix} -113,"Undefined header"' if line.endswith("?") else None

    def _set(self, argument: str) -> None:
        text = argument.strip()
        try:
            volts = float(text)
        except ValueError:
            volts = parse_leading_number(text)
            if volts is None:
                self.errors.append('-104,"Data type error"')
                return
        try:
            self.device.apply_voltage(volts)
        except DeviceRefused as exc:
            self.journal.setpoint("serial", volts, False, str(exc))
            self.errors.append('-222,"Data out of range"')
            return
        self.journal.setpoint("serial", volts, True)

    def respond(self, line: str) -> tuple[str | None, bool]:
        """Reply to ``line`` with the injected faults applied: ``(reply, drop_connection)``."""
        is_query = line.strip().endswith("?")
        if is_query and self.faults.take("dropped_connections"):
            return None, True
        reply = self.handle(line)
        if reply is None:
            return None, False
        if self.faults.take("silent_replies"):
            return None, False
        if self.faults.take("garbage_replies"):
            return GARBAGE, False
        return reply, False


class _Lines:
    """Split a byte stream into lines at a terminator (an unterminated flood is dropped)."""

    MAX_LINE = 65536

    def __init__(self, eol: bytes) -> None:
        self.eol = eol
        self.buffer = b""

    def feed(self, data: bytes) -> list[bytes]:
        self.buffer += data
        *lines, self.buffer = self.buffer.split(self.eol)
        if len(self.buffer) > self.MAX_LINE:
            self.buffer = b""
        return lines


class SerialSocketServer:
    """The line protocol on a TCP socket (``socket://host:port``)."""

    def __init__(self, protocol: LineProtocol, eol: bytes, reply_eol: bytes, encoding: str) -> None:
        self.protocol = protocol
        self.eol, self.reply_eol, self.encoding = eol, reply_eol, encoding
        self._server: asyncio.base_events.Server | None = None
        self._writers: set[asyncio.StreamWriter] = set()
        self.address: tuple[str, int] | None = None

    async def start(self, host: str, port: int) -> tuple[str, int]:
        self._server = await asyncio.start_server(self._client, host, port)
        sockname = self._server.sockets[0].getsockname()
        self.address = (sockname[0], sockname[1])
        return self.address

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._writers.add(writer)
        lines = _Lines(self.eol)
        try:
            while data := await reader.read(4096):
                for raw in lines.feed(data):
                    reply, drop = self.protocol.respond(raw.decode(self.encoding, errors="replace"))
                    if drop:
                        return
                    if reply is not None:
                        writer.write(reply.encode(self.encoding) + self.reply_eol)
                        await writer.drain()
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self._writers.discard(writer)
            writer.close()

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
            for w in list(self._writers):
                w.close()
            await self._server.wait_closed()
            self._server = None


class SerialPtyServer:
    """The line protocol on a pseudo-terminal: clients open :attr:`path` like a serial port."""

    def __init__(self, protocol: LineProtocol, eol: bytes, reply_eol: bytes, encoding: str) -> None:
        self.protocol = protocol
        self.eol, self.reply_eol, self.encoding = eol, reply_eol, encoding
        self._master = self._slave = -1
        self.path = ""
        self._lines = _Lines(eol)

    async def start(self) -> str:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing: bytes pass through as on a real line
        self.path = os.ttyname(self._slave)
        asyncio.get_running_loop().add_reader(self._master, self._readable)
        return self.path

    def _readable(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except OSError:
            return
        for raw in self._lines.feed(data):
            reply, drop = self.protocol.respond(raw.decode(self.encoding, errors="replace"))
            if reply is not None and not drop:
                os.write(self._master, reply.encode(self.encoding) + self.reply_eol)

    async def stop(self) -> None:
        if self._master >= 0:
            asyncio.get_running_loop().remove_reader(self._master)
            os.close(self._master)
            os.close(self._slave)
            self._master = self._slave = -1
