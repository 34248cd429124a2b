"""The serial driver end to end: the line protocol over socket:// and a pty, the bytes on the wire, faults."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from drivers import ConnectionFailed, DeviceError, DriverTimeout, LimitError, ProtocolError, open_rig
from drivers.config import loads_config
from drivers.serial.config import SerialConfig
from drivers.serial.backend import SerialLink
from drivers.sim.serial_server import IDENTITY
from identify import random_input
from rig.testing import EXACT, config, serial_toml, served

pytestmark = pytest.mark.timeout(60)

WHERE = ["socket"] + (["pty"] if sys.platform.startswith("linux") else [])


@pytest.mark.parametrize("where", WHERE)
def test_a_sequence_over_the_line_reproduces_the_device(where):
    with served(serial="pty" if where == "pty" else "socket://127.0.0.1:0", levels=8, **EXACT) as bench:
        url = bench.endpoints["serial"]
        assert url.startswith("/dev/") if where == "pty" else url.startswith("socket://127.0.0.1:")
        truth = bench.device.true_model()
        v = random_input(truth.grid, 15, seed=5)
        with open_rig(config(serial_toml(url))) as rig:
            assert rig.description["identity"] == IDENTITY
            y = []
            for x in v:
                rig.heater.set_voltage(x)
                y.append(rig.sensor.read().deflection_um)
        sent = [float(f"{x:.6f}") for x in v]  # SOUR:VOLT prints 6 decimals
        np.testing.assert_allclose(y, truth.predict(sent), rtol=0, atol=5e-8 * 5)  # 9 significant digits of PSD
        assert bench.journal.volts_received() == [0.0, *sent, 0.0]
        assert bench.device.applied_voltage == 0.0


def test_the_exact_lines_on_the_wire():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        with open_rig(config(serial_toml(bench.endpoints["serial"]))) as rig:
            del bench.journal.lines[:]
            rig.heater.set_voltage(1.25)
            rig.sensor.read()
            assert rig.heater.read_voltage() == 1.25
        assert bench.journal.lines == [
            "SOUR:VOLT 1.250000", "SOUR:VOLT?",  # set, verified
            "MEAS:DEFL?",
            "SOUR:VOLT?",
            "SOUR:VOLT 0.000000", "SOUR:VOLT?",  # closing: back to 0 V, verified
        ]


def test_a_configured_command_set_and_terminators():
    commands = "[serial.commands]\nset_voltage = 'VOLT {volts:.3f} V'\nquery_voltage = 'VOLT?'\nmeasure_psd = 'PSD?'\n"
    extra = "write_termination = '\\r\\n'\nread_termination = '\\r'\n" + commands
    with served(serial="socket://127.0.0.1:0", **EXACT) as probe:
        text = serial_toml(probe.endpoints["serial"], extra=extra)
    cfg = config(text)
    with served(serial="socket://127.0.0.1:0", serial_cfg=cfg.serial, **EXACT) as bench:
        with open_rig(config(serial_toml(bench.endpoints["serial"], extra=extra))) as rig:
            rig.heater.set_voltage(2.0004)
            assert rig.heater.last_written == 2.0  # printed with 3 decimals: what the instrument gets
            assert math.isfinite(rig.sensor.read().psd_V)
        assert "VOLT 2.000 V" in bench.journal.lines and "PSD?" in bench.journal.lines
        assert bench.journal.volts_received()[1] == 2.0


def test_limits_are_checked_before_a_line_is_sent():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        with open_rig(config(serial_toml(bench.endpoints["serial"]))) as rig:
            before = list(bench.journal.lines)
            for bad in (math.nan, math.inf, 6.5, -1.0):
                with pytest.raises(LimitError):
                    rig.heater.set_voltage(bad)
            assert bench.journal.lines == before
            # Rounding by the printed format cannot cross the limit either: 5.9999996 prints as 6.000000.
            rig.heater.set_voltage(5.9999996)
            assert bench.journal.volts_received()[-1] == 6.0


def test_the_instrument_refusing_a_value_is_a_named_device_error():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        toml = serial_toml(bench.endpoints["serial"]).replace("max_V = 6.0", "max_V = 12.0")
        toml = toml.replace("max_current_mA = 12.78", "max_current_mA = 20.0")
        with open_rig(config(toml)) as rig:
            rig.heater.set_voltage(3.0)
            with pytest.raises(DeviceError, match='reports 3 V; instrument error: -222,"Data out of range"'):
                rig.heater.set_voltage(11.0)  # within the config's limits, beyond the DAQ's 10 V
        assert [r.volts for r in bench.journal.setpoints if not r.accepted] == [11.0]


@pytest.mark.slow
def test_garbage_and_silence_are_retried_then_reported():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        with open_rig(config(serial_toml(bench.endpoints["serial"], timeout=0.2, retries=2))) as rig:
            bench.faults.garbage_replies = 2
            assert math.isfinite(rig.sensor.read().psd_V)
            bench.faults.silent_replies = 1
            assert math.isfinite(rig.sensor.read().psd_V)
            assert rig.heater.link.reconnections >= 1  # a late reply must not answer the next query
            bench.faults.garbage_replies = 50
            with pytest.raises(ProtocolError, match="not a number"):
                rig.sensor.read()
            bench.faults.garbage_replies = 0
            bench.faults.silent_replies = 50
            with pytest.raises(DriverTimeout, match="no reply"):
                rig.sensor.read()
            bench.faults.silent_replies = 0


def test_a_dropped_connection_is_reopened():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        with open_rig(config(serial_toml(bench.endpoints["serial"]))) as rig:
            rig.heater.set_voltage(1.0)
            bench.faults.dropped_connections = 1
            assert rig.heater.read_voltage() == 1.0
            assert rig.heater.link.reconnections >= 1


def test_nothing_listening_and_unknown_ports_fail_cleanly():
    with served(serial="socket://127.0.0.1:0", **EXACT) as bench:
        url = bench.endpoints["serial"]
    with pytest.raises(ConnectionFailed, match="Connection refused"):
        open_rig(config(serial_toml(url, retries=1)))
    with pytest.raises(ConnectionFailed, match="/dev/nonexistent-vo2"):
        open_rig(config(serial_toml("/dev/nonexistent-vo2", retries=0)))


def test_loop_url_opens_and_its_echo_is_garbage_to_a_query():
    cfg = loads_config(serial_toml("loop://", timeout=0.1, retries=1)).serial
    assert isinstance(cfg, SerialConfig)
    link = SerialLink(cfg)
    link.connect()
    try:
        with pytest.raises(ProtocolError, match="'MEAS:DEFL\\?' got 'MEAS:DEFL\\?', not a number"):
            link.query_number("MEAS:DEFL?")  # loop:// echoes the query back
    finally:
        link.close()
