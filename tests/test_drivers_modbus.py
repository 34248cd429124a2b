"""The modbus driver end to end against the simulated device on a real pymodbus server (loopback)."""

from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from drivers import ConnectionFailed, DriverTimeout, LimitError, open_rig
from drivers.modbus.config import ModbusConfig
from drivers.modbus.backend import ModbusLink
from drivers.modbus.errors import (
    DeviceBusy,
    DeviceFailure,
    GatewayTargetFailed,
    IllegalDataAddress,
    IllegalDataValue,
)
from drivers.modbus.registers import InputPoint, RegisterPoint
from identify import damped_oscillation, random_input
from rig.testing import EXACT, config, modbus_toml, served

pytestmark = pytest.mark.timeout(60)


def f32(x):
    return float(np.float32(x))


@pytest.mark.parametrize("transport", ["tcp", "rtu-over-tcp", "rtu"])
def test_a_sequence_through_each_transport_reproduces_the_device(transport):
    with served(modbus=True, modbus_rtu=True, levels=6, **EXACT) as bench:
        truth = bench.device.true_model()
        v = np.concatenate([damped_oscillation(truth.grid, thermal_term=True)[:12], random_input(truth.grid, 4, seed=1)])
        with open_rig(config(modbus_toml(bench, transport))) as rig:
            assert rig.device is None and rig.description["endpoint"].startswith(f"modbus {transport}")
            y = []
            for x in v:
                rig.heater.set_voltage(x)
                assert rig.heater.read_voltage() == f32(x)
                y.append(rig.sensor.read().deflection_um)
        # float32 on the wire: the set-points arrive rounded to float32, the PSD too (~1e-7 relative).
        np.testing.assert_allclose(y, truth.predict([f32(x) for x in v]), rtol=0, atol=5e-6)
        received = bench.journal.volts_received()
        assert received == [0.0] + [f32(x) for x in v] + [0.0]  # zeroed on opening and on closing
        assert all(r.accepted and r.transport == ("modbus" if transport == "tcp" else "modbus_rtu")
                   for r in bench.journal.setpoints)
        assert bench.device.applied_voltage == 0.0


def test_out_of_limit_setpoints_never_reach_the_server():
    with served(modbus=True, **EXACT) as bench:
        toml = modbus_toml(bench).replace("max_V = 6.0", "max_V = 8.0").replace("max_current_mA = 12.78", "max_current_mA = 5.0")
        with open_rig(config(toml)) as rig:
            assert rig.heater.window.max_V == pytest.approx(5e-3 * 782.5)  # the current binds: 3.91 V
            rig.heater.set_voltage(1.5)
            before = bench.journal.volts_received()
            for bad in (math.nan, math.inf, -math.inf, 4.0, 8.5, -0.1, 1e9):
                with pytest.raises(LimitError):
                    rig.heater.set_voltage(bad)
            assert bench.journal.volts_received() == before
            assert bench.device.applied_voltage == 1.5
        received = bench.journal.volts_received()
        assert all(math.isfinite(x) and 0.0 <= x <= 3.91 for x in received)
        assert received[-1] == 0.0


def test_the_server_refuses_what_the_client_should_never_send_with_a_named_error():
    with served(modbus=True, **EXACT) as bench:
        link = ModbusLink(config(modbus_toml(bench)).modbus)
        link.connect()
        try:
            point = link.cfg.setpoint
            for bad in (math.nan, 11.0):  # bypassing the heater's limits on purpose
                with pytest.raises(IllegalDataValue, match="Modbus exception 3"):
                    link.write(point, bad, "the heater set-point")
            refused = [r for r in bench.journal.setpoints if not r.accepted]
            assert len(refused) == 2 and math.isnan(refused[0].volts) and refused[1].volts == 11.0
            assert bench.device.applied_voltage == 0.0
            with pytest.raises(IllegalDataAddress, match="register map"):
                link.read(RegisterPoint(address=40, table="holding"), "nothing")
            # Half of a float32 is never applied.
            with pytest.raises(IllegalDataAddress):
                link.write(RegisterPoint(address=1, type="int16"), 1.0, "half a set-point")
            assert bench.device.applied_voltage == 0.0
        finally:
            link.close()


def test_a_wrong_register_map_fails_on_opening_with_the_exception_named():
    with served(modbus=True, **EXACT) as bench:
        toml = modbus_toml(bench, extra="[modbus.setpoint]\naddress = 100\n[modbus.psd]\naddress = 0\n")
        with pytest.raises(IllegalDataAddress, match="holding\\[100\\]"):
            open_rig(config(toml))


def test_a_wrong_unit_id_is_named():
    with served(modbus=True, **EXACT) as bench:
        toml = modbus_toml(bench).replace("[modbus]\n", "[modbus]\nunit_id = 7\n")
        with pytest.raises(GatewayTargetFailed, match="unit 7.*Modbus exception 11.*check unit_id"):
            open_rig(config(toml))
        assert bench.journal.setpoints == []


def test_scaled_integer_registers_round_and_are_checked_after_rounding():
    cfg = ModbusConfig.simulated(
        setpoint=RegisterPoint(address=4, type="int16", scale=1000.0),
        psd=InputPoint(address=8, type="int16", scale=1000.0),
    )
    extra = (
        "[modbus.setpoint]\naddress = 4\ntype = 'int16'\nscale = 1000.0\n"
        "[modbus.psd]\naddress = 8\ntype = 'int16'\nscale = 1000.0\n"
    )
    with served(modbus=True, modbus_cfg=cfg, **EXACT) as bench:
        truth = bench.device.true_model()
        toml = modbus_toml(bench, extra=extra).replace("max_V = 6.0", "max_V = 5.9996")
        with open_rig(config(toml)) as rig:
            rig.heater.set_voltage(1.2346)
            assert bench.journal.volts_received()[-1] == pytest.approx(1.235, abs=1e-12)
            assert rig.heater.read_voltage() == pytest.approx(1.235, abs=1e-12)
            reading = rig.sensor.read()
            expected = truth.predict([1.235])[0]
            assert reading.deflection_um == pytest.approx(expected, abs=0.5e-3 * 5.0)
            assert reading.psd_V == pytest.approx(round(expected / 5.0, 3), abs=1e-12)
            with pytest.raises(LimitError, match="on the wire"):
                rig.heater.set_voltage(5.9996)  # would arrive as 6.000 V
            assert bench.journal.volts_received()[-1] == pytest.approx(1.235)
            bench.faults.nan_readings = 1  # a NaN an int16 cannot carry: exception 4
            with pytest.raises(DeviceFailure, match="Modbus exception 4"):
                rig.sensor.read()


def test_transient_faults_are_retried_and_persistent_ones_named():
    with served(modbus=True, **EXACT) as bench:
        with open_rig(config(modbus_toml(bench, retries=2))) as rig:
            bench.faults.busy_replies = 2
            assert math.isfinite(rig.sensor.read().psd_V)
            bench.faults.nan_readings = 2  # float32 carries NaN: the sensor retries
            assert math.isfinite(rig.sensor.read().psd_V)
            bench.faults.busy_replies = 10
            with pytest.raises(DeviceBusy, match="Modbus exception 6"):
                rig.sensor.read()
            bench.faults.busy_replies = 0


def test_a_dropped_server_is_reconnected_with_backoff():
    with served(modbus=True, **EXACT) as bench:
        port = int(bench.endpoints["modbus"].rsplit(":", 1)[1])
        with open_rig(config(modbus_toml(bench, retries=6))) as rig:
            rig.heater.set_voltage(2.0)
            bench.call(bench.stop_endpoint("modbus"))
            restart = threading.Timer(0.15, lambda: bench.call(bench.start_modbus("127.0.0.1", port)))
            restart.start()
            t0 = time.perf_counter()
            reading = rig.sensor.read()
            restart.join()
            assert math.isfinite(reading.psd_V)
            assert rig.heater.link.reconnections >= 1
            assert time.perf_counter() - t0 >= 0.1
            assert rig.heater.read_voltage() == 2.0
        assert bench.device.applied_voltage == 0.0


def test_a_link_that_never_comes_back_raises_and_says_the_heater_state_is_unknown():
    with served(modbus=True, **EXACT) as bench:
        with pytest.raises(ConnectionFailed, match="refused or unreachable") as info:
            with open_rig(config(modbus_toml(bench, retries=1))) as rig:
                rig.heater.set_voltage(2.0)
                bench.call(bench.stop_endpoint("modbus"))
                rig.sensor.read()
        notes = getattr(info.value, "__notes__", [])
        assert any("heater state UNKNOWN: it may still be at 2 V" in n for n in notes), notes
        assert not rig.heater_state.confirmed and not rig.heater_state.acknowledged
        assert rig.heater_state.last_V == 2.0 and bench.device.applied_voltage == 2.0


def test_nothing_listening_fails_quickly_and_cleanly():
    with served(modbus=True, **EXACT) as bench:
        toml = modbus_toml(bench, retries=1)
    t0 = time.perf_counter()
    with pytest.raises(ConnectionFailed, match="connecting to modbus tcp 127.0.0.1:.*refused or unreachable"):
        open_rig(config(toml))
    assert time.perf_counter() - t0 < 5


def test_a_silent_server_times_out():
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(4)  # accepts connections in the kernel, never answers
        port = silent.getsockname()[1]
        toml = modbus_toml(f"127.0.0.1:{port}", timeout=0.2, retries=1)
        with pytest.raises(DriverTimeout, match="no reply after 2 attempt"):
            open_rig(config(toml))


SCRIPT = """
import sys, time
from drivers import open_rig, loads_config
with open_rig(loads_config(sys.stdin.read())) as rig:
    rig.heater.set_voltage(2.0)
    print("holding", flush=True)
    time.sleep(60)
"""


def test_ctrl_c_in_another_process_returns_the_heater_to_zero():
    with served(modbus=True, **EXACT) as bench:
        proc = subprocess.Popen(
            [sys.executable, "-c", SCRIPT], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
        )
        proc.stdin.write(modbus_toml(bench))
        proc.stdin.close()
        assert proc.stdout.readline().strip() == "holding"
        assert bench.device.applied_voltage == 2.0
        proc.send_signal(signal.SIGINT)
        proc.wait(20)
        assert proc.returncode != 0 and "KeyboardInterrupt" in proc.stderr.read()
        assert bench.journal.volts_received() == [0.0, 2.0, 0.0]
        assert bench.device.applied_voltage == 0.0


def test_after_a_reconnection_the_heater_checks_the_instrument_and_sends_its_setpoint_again():
    from drivers import ContinuityError
    from drivers.sim import SimParams, SimVO2
    from drivers.sim.bench import SimBench

    boot = "[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n[modbus.boot_id]\naddress = 2\ntype = 'uint32'\n"
    with served(modbus=True, **EXACT) as bench:
        port = int(bench.endpoints["modbus"].rsplit(":", 1)[1])
        with open_rig(config(modbus_toml(bench, retries=6, extra=boot))) as rig:
            rig.heater.set_voltage(2.0)
            assert rig.heater.verify() is False  # no reconnection: nothing on the wire
            n = len(bench.journal.setpoints)
            bench.call(bench.stop_endpoint("modbus"))  # the same device behind a new server: a link blip
            bench.call(bench.start_modbus("127.0.0.1", port))
            rig.sensor.read()  # reconnects
            assert rig.heater.verify() is True
            assert bench.journal.volts_received()[n:] == [2.0]  # the set-point, sent again
            assert rig.heater.verify() is False
            bench.call(bench.stop_endpoint("modbus"))
            fresh = SimBench(SimVO2(SimParams(**EXACT), bench.device.clock), bench.modbus_cfg).start_in_thread()
            try:
                fresh.call(fresh.start_modbus("127.0.0.1", port))  # a restarted instrument on the same port
                fresh.device.apply_voltage(2.0)  # even holding the same output, it is not the same instrument
                rig.sensor.read()
                with pytest.raises(ContinuityError, match="restarted.*boot id"):
                    rig.heater.verify()
            finally:
                rig.close()
                fresh.close()
            assert rig.heater_state.confirmed and fresh.device.applied_voltage == 0.0
