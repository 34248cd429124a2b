"""``[serial]``: the ``serial`` backend's table of ``rig.toml`` -- the line and its commands."""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..configschema import setting
from ..retry import LinkConfig


@dataclass(frozen=True, kw_only=True)
class SerialCommands:
    """``[serial.commands]``: the line protocol (SCPI-like by default)."""

    set_voltage: str = setting(
        "command that sets the heater; '{volts}' is replaced by the set-point (Python format spec allowed)",
        default="SOUR:VOLT {volts:.6f}",
    )
    query_voltage: str = setting("query answered by the set-point in volts", default="SOUR:VOLT?")
    measure_psd: str = setting("query answered by the PSD voltage in volts", default="MEAS:DEFL?")
    identify: str = setting("identification query", default="*IDN?")
    error_query: str = setting("query answered by the instrument's last error ('' if none)", default="SYST:ERR?")
    error_prefix: str = setting("a reply starting with this is an error report", default="ERR")

    def __post_init__(self) -> None:
        try:
            text = self.set_voltage.format(volts=1.25)
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"set_voltage must contain '{{volts}}' and nothing else to fill: {exc}") from None
        if text == self.set_voltage:
            raise ValueError("set_voltage must contain '{volts}'")
        if self.value_on_wire(1.25) is None:
            raise ValueError(f"set_voltage {self.set_voltage!r} does not print the value as a number")
        for name in ("query_voltage", "measure_psd", "identify"):
            if not getattr(self, name).strip():
                raise ValueError(f"{name} must not be empty")

    def format_set(self, volts: float) -> str:
        return self.set_voltage.format(volts=volts)

    @property
    def set_prefix(self) -> str:
        """The constant text before the value in :attr:`set_voltage`."""
        return self.set_voltage.split("{", 1)[0]

    def value_on_wire(self, volts: float) -> float | None:
        """The number the instrument reads from the set command for ``volts`` (after printing)."""
        return parse_leading_number(self.format_set(volts)[len(self.set_prefix):])


_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


def parse_leading_number(text: str) -> float | None:
    """The decimal number at the start of ``text`` (after blanks), or None."""
    m = _NUMBER.match(text)
    return float(m.group(1)) if m else None


@dataclass(frozen=True, kw_only=True)
class SerialConfig(LinkConfig):
    """``[serial]``: a pyserial line and its ASCII commands."""

    url: str = setting("serial port or pyserial URL: /dev/ttyUSB0, socket://host:port, loop://")
    baudrate: int = setting("serial speed (ignored by socket://)", default=115200, positive=True)
    write_termination: str = setting("appended to every command", default="\n")
    read_termination: str = setting("ends every reply", default="\n")
    encoding: str = setting("text encoding of the line", default="ascii")
    verify_set: bool = setting("read the set-point back after each write and compare", default=True)
    commands: SerialCommands = setting("[serial.commands] the command set", default_factory=SerialCommands)

    def __post_init__(self) -> None:
        if not self.write_termination or not self.read_termination:
            raise ValueError("terminations must not be empty")
        try:
            "x".encode(self.encoding)
        except LookupError:
            raise ValueError(f"unknown encoding {self.encoding!r}") from None
