"""`rig serve-sim` and `rig selftest` as a user runs them: separate processes, real sockets, a pty."""

from __future__ import annotations

import socket
import sys

import pytest

from rig.testing import HEADER, REGISTER_MAP

from .cli import assert_one_line_error, rig_here, serve_sim, stop

pytestmark = pytest.mark.timeout(120)

SELFTEST_KEYS = {"driver", "connected", "heater_ok", "sensor_ok", "deflection_um", "safe_state"}


def test_selftest_on_the_built_in_simulated_device():
    run = rig_here("selftest", "--json")
    assert run.code == 0, run.err
    report = run.json()
    assert SELFTEST_KEYS <= set(report)
    assert report["driver"] == "sim" and report["passed"] is True
    assert all(report[k] is True for k in ("connected", "heater_ok", "sensor_ok", "safe_state"))
    assert report["deflection_um"] == pytest.approx(-13.0, abs=0.05)  # mu0 - amplitude at rest
    assert report["readback_V"] == report["test_voltage_V"] == 0.5


@pytest.mark.slow
def test_selftest_passes_against_serve_sim_and_fails_cleanly_once_it_is_gone(tmp_path):
    serial_at = "pty" if sys.platform.startswith("linux") else "socket://127.0.0.1:0"
    proc, endpoints = serve_sim("--modbus", "127.0.0.1:0", "--serial", serial_at)
    try:
        assert set(endpoints) == {"modbus", "serial"}
        host, port = endpoints["modbus"].rsplit(":", 1)
        assert host == "127.0.0.1"
        modbus = tmp_path / "modbus.toml"
        modbus.write_text(HEADER.format(driver="modbus") + f"[modbus]\nport = {port}\nretries = 1\n" + REGISTER_MAP)
        serial = tmp_path / "serial.toml"
        serial.write_text(HEADER.format(driver="serial") + f"[serial]\nurl = \"{endpoints['serial']}\"\n")

        run = rig_here("selftest", "--config", modbus, "--json")
        assert run.code == 0, run.err
        report = run.json()
        assert SELFTEST_KEYS <= set(report)
        assert report["driver"] == "modbus" and report["passed"] and report["endpoint"].startswith("modbus tcp")
        assert report["readback_V"] == 0.5 and report["deflection_um"] == pytest.approx(-13.0, abs=0.05)

        run = rig_here("selftest", "--config", serial)  # over a pseudo-terminal, as over a real serial port
        assert run.code == 0, run.err
        assert "PASSED" in run.out and endpoints["serial"] in run.out
    finally:
        code, err = stop(proc)
    assert code == 0
    # Per self-test: 0 V on opening, 0.5 V, 0 V, 0 V on closing -- all accepted, heater left at 0 V.
    assert "8 set-point request(s) received, 0 refused; heater at 0 V" in err

    run = rig_here("selftest", "--config", modbus, "--json")
    assert run.code == 3  # a fault of the instrument or its link, as for rig acquire (1 is an internal error)
    report = run.json()
    assert SELFTEST_KEYS <= set(report)
    assert report["connected"] is False and report["safe_state"] is False and report["passed"] is False
    assert "refused or unreachable" in report["error"]
    assert "Traceback" not in run.err
    # the table claims nothing that was not read (issue 28, item 8)
    run = rig_here("selftest", "--config", modbus)
    assert run.code == 3 and "read back at 0 V" not in run.out, run.out
    assert "nothing was driven or read" in run.out and "not run" in run.out


def test_bad_invocations_are_one_line_errors(tmp_path):
    bad = tmp_path / "rig.toml"
    bad.write_text(HEADER.format(driver="modbus").replace("max_V", "max_v"))
    assert_one_line_error(rig_here("selftest", "--config", bad), "unknown key 'heater.max_v'", "did you mean 'heater.max_V'")
    assert_one_line_error(rig_here("serve-sim", "--modbus", "0.0.0.0:0"), "not a loopback address", "--allow-remote")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        assert_one_line_error(rig_here("serve-sim", "--modbus", f"127.0.0.1:{port}"),
                              f"--modbus 127.0.0.1:{port}: the address is already in use", "port 0")


@pytest.mark.slow
def test_an_address_in_use_is_named_with_the_port_0_way_out(tmp_path):
    # issue 17, finding 7: pymodbus said "Could not start listen, please check address"
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        for option, value in (("--modbus", f"127.0.0.1:{port}"), ("--modbus-rtu", f"127.0.0.1:{port}"),
                              ("--serial", f"socket://127.0.0.1:{port}")):
            run = rig_here("serve-sim", option, value)
            assert_one_line_error(run, f"{option} {value}: the address is already in use", f"{option} ",
                                  ":0", "prints the port it chose")
            assert "check address" not in run.err
        config = tmp_path / "rig.toml"
        config.write_text(HEADER.format(driver="modbus") + f"[modbus]\nport = {port}\n" + REGISTER_MAP)
        assert_one_line_error(rig_here("serve-sim", "--config", config), "already in use", "--modbus 127.0.0.1:0")
    # port 0: the system's choice, printed
    proc, endpoints = serve_sim("--modbus", "127.0.0.1:0")
    try:
        host, chosen = endpoints["modbus"].rsplit(":", 1)
        assert host == "127.0.0.1" and int(chosen) > 0
        with socket.create_connection(("127.0.0.1", int(chosen))):
            pass
    finally:
        assert stop(proc)[0] == 0
