"""The Modbus register map: where the heater set-point and the PSD live, and how they are encoded.

A :class:`RegisterPoint` is one value on the instrument: its table
(``holding`` registers are read/write, ``input`` registers read-only), its
address and its data type.  Addresses are the 0-based protocol addresses
that go on the wire -- *not* the "40001"-style numbers of some manuals (for
those, subtract 40001 or 30001).  Nothing in this project adds hidden
offsets.

Encoding (pure functions, tested by the exact registers they produce):

* ``float32`` / ``float64``: IEEE 754, ``value * scale``;
* ``int16`` / ``uint16`` / ``int32`` / ``uint32``: ``round(value * scale)``;
  a value that does not fit (or is not finite) raises :class:`CodecError`
  -- it is never wrapped or clipped;
* each 16-bit register is big-endian (the Modbus standard); multi-register
  values are sent most significant word first (``word_order = "big"``,
  "ABCD") or least significant first (``"little"``, "CDAB").
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from ..configschema import setting
from ..errors import CodecError

#: struct code and register count of each data type.
DATA_TYPES: dict[str, tuple[str, int]] = {
    "float32": ("f", 2),
    "float64": ("d", 4),
    "int16": ("h", 1),
    "uint16": ("H", 1),
    "int32": ("i", 2),
    "uint32": ("I", 2),
}
INTEGER_RANGES: dict[str, tuple[int, int]] = {
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
}
TABLES = ("holding", "input")


@dataclass(frozen=True, kw_only=True)
class RegisterPoint:
    """One value in the instrument's register map."""

    address: int = setting("0-based protocol address of the first register", minimum=0, maximum=65535)
    table: str = setting(
        "register table: 'holding' (read/write) or 'input' (read-only)",
        default="holding",
        choices=TABLES,
    )
    type: str = setting(
        "data type: float32, float64, int16, uint16, int32 or uint32",
        default="float32",
        choices=tuple(DATA_TYPES),
    )
    scale: float = setting(
        "register value = physical value x scale (e.g. 1000 for millivolts in an int16)",
        default=1.0,
        positive=True,
    )
    word_order: str = setting(
        "order of 16-bit words in multi-register values: 'big' (ABCD) or 'little' (CDAB)",
        default="big",
        choices=("big", "little"),
    )

    def __post_init__(self) -> None:
        if self.address + self.count - 1 > 65535:
            raise ValueError(f"a {self.type} at address {self.address} runs past register 65535")

    @property
    def count(self) -> int:
        """Number of 16-bit registers the value occupies."""
        return DATA_TYPES[self.type][1]

    @property
    def is_integer(self) -> bool:
        return self.type in INTEGER_RANGES

    @property
    def resolution(self) -> float:
        """Smallest step of the physical value (0 for floating-point types)."""
        return 1.0 / self.scale if self.is_integer else 0.0

    def raw(self, value: float) -> float | int:
        """The number stored in the register(s) for physical ``value``; :class:`CodecError` if impossible."""
        value = float(value)
        if not math.isfinite(value):
            if self.is_integer:
                raise CodecError(f"{value} cannot be stored in an {self.type} register")
            return value * self.scale
        scaled = value * self.scale
        if not self.is_integer:
            if self.type == "float32" and abs(scaled) > 3.4028234663852886e38:
                raise CodecError(f"{value} overflows a float32 register")
            return scaled
        raw = round(scaled)
        lo, hi = INTEGER_RANGES[self.type]
        if not lo <= raw <= hi:
            raise CodecError(
                f"{value:g} x scale {self.scale:g} = {raw} does not fit an {self.type} register [{lo}, {hi}]"
            )
        return raw

    def encode(self, value: float) -> list[int]:
        """Registers (each 0..65535) holding physical ``value``."""
        code, count = DATA_TYPES[self.type]
        data = struct.pack(">" + code, self.raw(value))
        words = [int.from_bytes(data[2 * k : 2 * k + 2], "big") for k in range(count)]
        return words[::-1] if self.word_order == "little" else words

    def decode(self, registers: list[int] | tuple[int, ...]) -> float:
        """Physical value held in ``registers``; :class:`CodecError` on a wrong count or a bad word."""
        code, count = DATA_TYPES[self.type]
        regs = list(registers)
        if len(regs) != count:
            raise CodecError(f"a {self.type} needs {count} register(s), got {len(regs)}")
        if any(not isinstance(r, int) or not 0 <= r <= 0xFFFF for r in regs):
            raise CodecError(f"register values must be 16-bit words, got {regs}")
        if self.word_order == "little":
            regs = regs[::-1]
        data = b"".join(r.to_bytes(2, "big") for r in regs)
        return struct.unpack(">" + code, data)[0] / self.scale

    def on_wire(self, value: float) -> float:
        """What the instrument will read back after storing ``value`` (rounding included)."""
        return self.decode(self.encode(value))

    def describe(self) -> str:
        return f"{self.table}[{self.address}] {self.type} x{self.scale:g} ({self.word_order} word order)"


@dataclass(frozen=True, kw_only=True)
class InputPoint(RegisterPoint):
    """A measured value: the same as :class:`RegisterPoint`, in the input table unless told otherwise."""

    table: str = setting(
        "register table: 'input' (read-only) or 'holding' (read/write)",
        default="input",
        choices=TABLES,
    )


def overlap(a: RegisterPoint, b: RegisterPoint) -> bool:
    """Whether two points share a register of the same table."""
    return a.table == b.table and a.address < b.address + b.count and b.address < a.address + a.count
