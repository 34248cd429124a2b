"""A simulated bench: one :class:`SimVO2` behind real protocol servers, on loopback.

``rig serve-sim`` runs it in the foreground; tests run it on a background
thread (:meth:`SimBench.start_in_thread`) with port 0 and read the bound
addresses from :attr:`SimBench.endpoints`.  All servers share one asyncio
loop, so the device sees one request at a time.

Endpoints (any combination):

* ``modbus``: Modbus TCP;
* ``modbus_rtu``: Modbus RTU frames over a TCP socket (a serial-to-Ethernet
  converter, or ``transport = "rtu"`` with ``url = "socket://..."``);
* ``serial``: the line protocol on ``socket://host:port``, or on a
  pseudo-terminal (``"pty"``).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine
from concurrent.futures import Future
from typing import Any

from pymodbus import FramerType

from ..errors import ConfigError, ServeError
from ..modbus.config import ModbusConfig
from ..net import is_loopback
from ..serial.config import SerialConfig
from .device import SimVO2
from .faults import FaultPlan
from .journal import Journal
from .modbus_server import SimModbusHandler, SimModbusServer
from .serial_server import LineProtocol, SerialPtyServer, SerialSocketServer


def parse_host_port(text: str, what: str, allow_remote: bool = False) -> tuple[str, int]:
    """``HOST:PORT`` or ``PORT`` (loopback) -> ``(host, port)``; non-loopback hosts need ``allow_remote``."""
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = "127.0.0.1", text
    host = host.strip("[]") or "127.0.0.1"
    try:
        port = int(port_text)
    except ValueError:
        raise ConfigError(f"{what}: {text!r} is not HOST:PORT") from None
    if not 0 <= port <= 65535:
        raise ConfigError(f"{what}: port {port} is out of range")
    if not allow_remote and not is_loopback(host):
        raise ConfigError(
            f"{what}: {host} is not a loopback address; the simulated bench listens on loopback "
            "only unless --allow-remote is given"
        )
    return host, port


def endpoints_from_config(modbus: ModbusConfig | None, serial: SerialConfig | None) -> dict[str, str]:
    """Where ``rig serve-sim --config`` listens when given no endpoint: where the client of the config's
    ``[modbus]`` and ``[serial]`` tables connects.

    ``{"modbus": "HOST:PORT"}`` for Modbus TCP, ``{"modbus_rtu": ...}`` for
    RTU over TCP (or RTU on a ``socket://`` URL), ``{"serial": "socket://..."}``
    for a serial line on a ``socket://`` URL; device paths are not served.
    """
    out: dict[str, str] = {}
    if modbus is not None:
        m = modbus
        if m.transport == "tcp":
            out["modbus"] = f"{m.host}:{m.port}"
        elif m.transport == "rtu-over-tcp":
            out["modbus_rtu"] = f"{m.host}:{m.port}"
        elif m.url and m.url.startswith("socket://"):
            out["modbus_rtu"] = m.url.removeprefix("socket://")
    if serial is not None and serial.url.startswith("socket://"):
        out["serial"] = serial.url
    return out


class SimBench:
    """The device, its servers, the journal of what they received, and the faults to inject."""

    def __init__(
        self,
        device: SimVO2,
        modbus: ModbusConfig | None = None,
        serial: SerialConfig | None = None,
    ) -> None:
        self.device = device
        self.modbus_cfg = modbus or ModbusConfig.simulated()
        self.serial_cfg = serial or SerialConfig(url="socket://127.0.0.1:0")
        self.faults = device.faults
        self.journal = Journal()
        #: Bound endpoints by name: "modbus" -> "127.0.0.1:5020", "serial" -> "socket://..." or a pty path.
        self.endpoints: dict[str, str] = {}
        self._servers: dict[str, Any] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ async API
    async def start_modbus(self, host: str, port: int, rtu: bool = False) -> str:
        name = "modbus_rtu" if rtu else "modbus"
        self._check_free(name)
        handler = SimModbusHandler(self.device, self.modbus_cfg, self.journal, self.faults, name)
        server = SimModbusServer(handler, FramerType.RTU if rtu else FramerType.SOCKET)
        try:
            h, p = await server.start(host, port)
        except (OSError, RuntimeError) as exc:
            raise ServeError(f"cannot serve {name} on {host}:{port}: {exc}") from None
        self._servers[name] = server
        self.endpoints[name] = f"{h}:{p}"
        return self.endpoints[name]

    async def start_serial(self, where: str) -> str:
        """``where``: ``"pty"``, ``"socket://HOST:PORT"`` or ``"HOST:PORT"``."""
        self._check_free("serial")
        cfg = self.serial_cfg
        protocol = LineProtocol(self.device, cfg.commands, self.journal, self.faults)
        eol = cfg.write_termination.encode(cfg.encoding)
        reply_eol = cfg.read_termination.encode(cfg.encoding)
        if where == "pty":
            server = SerialPtyServer(protocol, eol, reply_eol, cfg.encoding)
            self.endpoints["serial"] = await server.start()
        else:
            host, port = parse_host_port(where.removeprefix("socket://"), "serial", allow_remote=True)
            server = SerialSocketServer(protocol, eol, reply_eol, cfg.encoding)
            try:
                h, p = await server.start(host, port)
            except OSError as exc:
                raise ServeError(f"cannot serve the serial line on {host}:{port}: {exc}") from None
            self.endpoints["serial"] = f"socket://{h}:{p}"
        self._servers["serial"] = server
        return self.endpoints["serial"]

    def _check_free(self, name: str) -> None:
        if name in self._servers:
            raise RuntimeError(f"the {name} endpoint is already being served")

    async def stop_endpoint(self, name: str) -> None:
        server = self._servers.pop(name, None)
        self.endpoints.pop(name, None)
        if server is not None:
            await server.stop()

    async def stop_all(self) -> None:
        for name in list(self._servers):
            await self.stop_endpoint(name)

    # ------------------------------------------------------------ on a thread
    def start_in_thread(self) -> "SimBench":
        """Run the event loop on a daemon thread; then use :meth:`call` to start servers."""
        ready = threading.Event()

        def run() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            asyncio.set_event_loop(loop)
            ready.set()
            loop.run_forever()
            loop.close()

        self._thread = threading.Thread(target=run, name="sim-bench", daemon=True)
        self._thread.start()
        ready.wait()
        return self

    def call(self, coro: Coroutine[Any, Any, Any], timeout: float = 10.0) -> Any:
        """Run a coroutine of this bench on its thread and wait for the result."""
        if self._loop is None:
            raise RuntimeError("the bench is not running on a thread")
        fut: Future = asyncio.run_coroutine_threadsafe(coro, self._loop)
        return fut.result(timeout)

    def close(self) -> None:
        """Stop every server and the thread."""
        if self._loop is None:
            return
        try:
            self.call(self.stop_all())
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            if self._thread is not None:
                self._thread.join(5)
            self._loop = None

    def __enter__(self) -> "SimBench":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
