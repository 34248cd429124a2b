"""The simulated device behind a real pymodbus server (Modbus TCP, or RTU framing over TCP).

Built on pymodbus 3.16's ``SimDevice``/``SimData`` datastore, whose
``action`` coroutine sees every request before it is answered:

* a write to the heater set-point must cover exactly its registers (a
  half-written float is refused with exception 2); the value is decoded,
  journalled, and applied to the device -- a NaN, infinite or over-range
  value is refused with exception 3 (illegal data value) and not applied;
* a read of the set-point returns what the device is applying; a read of
  the PSD register triggers one PSD reading (a NaN that the register type
  cannot hold is answered with exception 4, device failure); the boot-id
  register (when the map has one) holds the device's
  :attr:`~drivers.sim.SimVO2.boot_id`, new at every power-up, and the
  full-scale register its ``max_output_V``;
* every other address is invalid (exception 2); another unit id gets
  exception 11, as from a gateway.

Addresses are the protocol's 0-based ones, the same numbers as in
``rig.toml``; no offsets anywhere.
"""

from __future__ import annotations

import asyncio

from pymodbus import FramerType
from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from ..errors import CodecError
from ..modbus.config import ModbusConfig
from ..modbus.errors import quiet_pymodbus
from ..modbus.registers import INTEGER_RANGES, RegisterPoint
from .device import DeviceRefused, SimVO2
from .faults import FaultPlan
from .journal import Journal

quiet_pymodbus()

_WRITE_CODES = frozenset({6, 16, 23})
_TABLE_CODES = {"holding": frozenset({3, 6, 16, 22, 23}), "input": frozenset({4})}


def _block(points: list[RegisterPoint]) -> list[SimData]:
    if not points:
        return [SimData(0, datatype=DataType.INVALID)]
    return [SimData(p.address, count=p.count, values=0, datatype=DataType.REGISTERS)
            for p in sorted(points, key=lambda p: p.address)]


def boot_words(point: RegisterPoint, boot_id: int) -> list[int]:
    """The registers of ``point`` holding a 32-bit boot id, folded into what its type can carry."""
    if point.is_integer:
        lo, hi = INTEGER_RANGES[point.type]
        return point.encode((lo + boot_id % (hi - lo + 1)) / point.scale)
    return point.encode(boot_id / point.scale)


async def _no_such_unit(*_: object) -> ExcCodes:
    return ExcCodes.GATEWAY_NO_RESPONSE


class SimModbusHandler:
    """The register map of one simulated unit, answering pymodbus's datastore callbacks."""

    def __init__(self, device: SimVO2, cfg: ModbusConfig, journal: Journal, faults: FaultPlan, transport: str) -> None:
        self.device = device
        self.cfg = cfg
        self.journal = journal
        self.faults = faults
        self.transport = transport

    def simdevices(self) -> list[SimDevice]:
        """The pymodbus device descriptions: our unit (separate holding and input tables) and,
        as a gateway would, "target device failed to respond" (exception 11) for any other unit id."""
        points = list(self.cfg.points().values())

        def tables() -> tuple[list[SimData], ...]:
            bits = SimData(0, count=16, values=False, datatype=DataType.BITS)
            holding = _block([p for p in points if p.table == "holding"])
            inputs = _block([p for p in points if p.table == "input"])
            return [bits], [bits], holding, inputs

        unit = SimDevice(self.cfg.unit_id, simdata=tables(), action=self.action)
        if self.cfg.unit_id == 0:
            return [unit]
        return [unit, SimDevice(0, simdata=tables(), action=_no_such_unit)]

    @staticmethod
    def _touches(point: RegisterPoint, func_code: int, address: int, count: int) -> bool:
        return (
            func_code in _TABLE_CODES[point.table]
            and address < point.address + point.count
            and point.address < address + count
        )

    async def action(
        self, func_code: int, start: int, address: int, count: int, registers: list[int], values: list | None
    ) -> ExcCodes | None:
        if self.faults.take("busy_replies"):
            return ExcCodes.DEVICE_BUSY
        sp, psd = self.cfg.setpoint, self.cfg.psd
        if func_code in _WRITE_CODES and values is not None:
            if not self._touches(sp, func_code, address, count):
                return ExcCodes.ILLEGAL_ADDRESS
            if address != sp.address or count != sp.count:
                return ExcCodes.ILLEGAL_ADDRESS  # never apply half a value
            return self._write_setpoint([int(v) for v in values])
        if self._touches(sp, func_code, address, count):
            registers[sp.address - start : sp.address - start + sp.count] = sp.encode(self.device.applied_voltage)
        if self._touches(psd, func_code, address, count):
            try:
                words = psd.encode(self.device.read_psd())
            except CodecError:
                return ExcCodes.DEVICE_FAILURE
            registers[psd.address - start : psd.address - start + psd.count] = words
        boot = self.cfg.boot_id
        if boot is not None and self._touches(boot, func_code, address, count):
            registers[boot.address - start : boot.address - start + boot.count] = boot_words(boot, self.device.boot_id)
        fs = self.cfg.full_scale
        if fs is not None and self._touches(fs, func_code, address, count):
            registers[fs.address - start : fs.address - start + fs.count] = fs.encode(self.device.params.max_output_V)
        return None

    def _write_setpoint(self, words: list[int]) -> ExcCodes | None:
        volts = self.cfg.setpoint.decode(words)
        try:
            self.device.apply_voltage(volts)
        except DeviceRefused as exc:
            self.journal.setpoint(self.transport, volts, False, str(exc))
            return ExcCodes.ILLEGAL_VALUE
        self.journal.setpoint(self.transport, volts, True)
        return None


class SimModbusServer:
    """One listening pymodbus server for the device."""

    def __init__(self, handler: SimModbusHandler, framer: FramerType) -> None:
        self.handler = handler
        self.framer = framer
        self._server: ModbusTcpServer | None = None
        self.address: tuple[str, int] | None = None

    async def start(self, host: str, port: int) -> tuple[str, int]:
        """Listen on ``host:port`` (port 0: any free port); returns the bound address."""
        server = ModbusTcpServer(self.handler.simdevices(), framer=self.framer, address=(host, port))
        await server.serve_forever(background=True)
        self._server = server
        sockname = server.transport.sockets[0].getsockname()
        self.address = (sockname[0], sockname[1])
        return self.address

    async def stop(self) -> None:
        if self._server is not None:
            await self._server.shutdown()
            self._server = None
            await asyncio.sleep(0)
