"""``[modbus]``: the ``modbus`` backend's table of ``rig.toml`` -- the link and the register map."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..configschema import setting
from ..retry import LinkConfig
from .registers import InputPoint, RegisterPoint, overlap

MODBUS_TRANSPORTS = ("tcp", "rtu-over-tcp", "rtu")


@dataclass(frozen=True, kw_only=True)
class ModbusConfig(LinkConfig):
    """``[modbus]``: a pymodbus client and the register map."""

    transport: str = setting(
        "'tcp' (Modbus TCP), 'rtu-over-tcp' (RTU frames over a TCP socket) or 'rtu' (RTU on a serial line)",
        default="tcp", choices=MODBUS_TRANSPORTS,
    )
    host: str = setting("server address for tcp and rtu-over-tcp", default="127.0.0.1")
    port: int = setting("server TCP port for tcp and rtu-over-tcp", default=502, minimum=1, maximum=65535)
    url: str | None = setting("serial port or pyserial URL for rtu (/dev/ttyUSB0, socket://host:port)", default=None)
    baudrate: int = setting("serial speed for rtu", default=19200, positive=True)
    parity: str = setting("serial parity for rtu: 'N', 'E' or 'O'", default="N", choices=("N", "E", "O"))
    stopbits: int = setting("serial stop bits for rtu", default=1, choices=(1, 2))
    bytesize: int = setting("serial data bits for rtu", default=8, choices=(7, 8))
    unit_id: int = setting("Modbus unit (slave) id of the instrument", default=1, minimum=0, maximum=247)
    setpoint: RegisterPoint = setting("[modbus.setpoint] the heater set-point register (V), a holding register")
    psd: InputPoint = setting("[modbus.psd] the PSD voltage register (V)")
    boot_id: InputPoint | None = setting(
        "[modbus.boot_id] optional: a register whose value changes whenever the instrument restarts "
        "(a boot counter or random boot id), read on opening and after every reconnection",
        default=None,
    )
    full_scale: InputPoint | None = setting(
        "[modbus.full_scale] optional: a register holding the heater output's full scale (V), read on opening",
        default=None,
    )

    def points(self) -> dict[str, RegisterPoint]:
        """Every configured register by its table name (``setpoint``, ``psd``, and the optional ones)."""
        named = {"setpoint": self.setpoint, "psd": self.psd, "boot_id": self.boot_id, "full_scale": self.full_scale}
        return {name: p for name, p in named.items() if p is not None}

    def __post_init__(self) -> None:
        if self.transport == "rtu" and not self.url:
            raise ValueError("transport = 'rtu' needs url (the serial port)")
        if self.setpoint.table != "holding":
            raise ValueError("the heater set-point must be a holding register (it is written)")
        named = list(self.points().items())
        for i, (a, pa) in enumerate(named):
            for b, pb in named[i + 1:]:
                if overlap(pa, pb):
                    raise ValueError(f"the {a} and {b} registers overlap")

    @classmethod
    def simulated(cls, **changes: Any) -> "ModbusConfig":
        """The simulated bench's default: float32 set-point in holding 0, float32 PSD in input 0,
        the boot id as a uint32 in input 2, the output's full scale as a float32 in input 4."""
        changes.setdefault("setpoint", RegisterPoint(address=0))
        changes.setdefault("psd", InputPoint(address=0))
        changes.setdefault("boot_id", InputPoint(address=2, type="uint32"))
        changes.setdefault("full_scale", InputPoint(address=4))
        return cls(**changes)

    def endpoint(self) -> str:
        """Where the instrument is, for messages."""
        if self.transport == "rtu":
            return f"modbus rtu {self.url} unit {self.unit_id}"
        return f"modbus {self.transport} {self.host}:{self.port} unit {self.unit_id}"
