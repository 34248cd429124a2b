"""Test helpers for the drivers: a simulated bench on loopback, and rig.toml texts that point at it."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from drivers.clock import RealClock
from drivers.config import RigConfig, loads_config
from drivers.modbus.config import ModbusConfig
from drivers.serial.config import SerialConfig
from drivers.sim import SimParams, SimVO2
from drivers.sim.bench import SimBench

#: A quiet, instantaneous device: every reading is equation (22) exactly (up to the wire's precision).
EXACT = dict(time_constant_s=0.0, psd_noise_V=0.0)

HEADER = """
driver = "{driver}"
[heater]
max_V = 6.0
max_current_mA = 12.78
series_resistance_ohm = 682.5
heater_resistance_ohm = 100.0
[sensor]
um_per_V = 5.0
"""

#: The simulated bench's default register map.
REGISTER_MAP = "[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n"

FAST_LINK = "timeout_s = {timeout}\nretries = {retries}\nbackoff_s = 0.02\nbackoff_max_s = 0.1\n"


@contextlib.contextmanager
def served(
    *,
    modbus: bool = False,
    modbus_rtu: bool = False,
    serial: str | None = None,
    modbus_cfg: ModbusConfig | None = None,
    serial_cfg: SerialConfig | None = None,
    **params,
) -> Iterator[SimBench]:
    """A :class:`SimBench` on a background thread, serving on free loopback ports."""
    device = SimVO2(SimParams(**params), RealClock())
    bench = SimBench(device, modbus_cfg, serial_cfg).start_in_thread()
    try:
        if modbus:
            bench.call(bench.start_modbus("127.0.0.1", 0))
        if modbus_rtu:
            bench.call(bench.start_modbus("127.0.0.1", 0, rtu=True))
        if serial:
            bench.call(bench.start_serial(serial))
        yield bench
    finally:
        bench.close()


def modbus_toml(
    bench: SimBench | str,
    transport: str = "tcp",
    extra: str = "",
    timeout: float = 1.0,
    retries: int = 2,
) -> str:
    """rig.toml text for the Modbus driver talking to ``bench`` (or to ``"host:port"``)."""
    if isinstance(bench, str):
        endpoint = bench
    else:
        endpoint = bench.endpoints["modbus" if transport == "tcp" else "modbus_rtu"]
    host, port = endpoint.rsplit(":", 1)
    if transport == "rtu":
        where = f'url = "socket://{endpoint}"\nbaudrate = 115200\n'
    else:
        where = f'host = "{host}"\nport = {port}\n'
    return (
        HEADER.format(driver="modbus")
        + f'[modbus]\ntransport = "{transport}"\n{where}'
        + FAST_LINK.format(timeout=timeout, retries=retries)
        + (extra or REGISTER_MAP)
    )


def serial_toml(url: str, extra: str = "", timeout: float = 1.0, retries: int = 2) -> str:
    """rig.toml text for the serial driver on ``url``."""
    return HEADER.format(driver="serial") + f'[serial]\nurl = "{url}"\n' + FAST_LINK.format(
        timeout=timeout, retries=retries
    ) + extra


def config(text: str) -> RigConfig:
    return loads_config(text, "test rig.toml")
