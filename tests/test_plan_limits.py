"""Limits at plan time: every set-point is checked as the wire will carry it -- rounding, register scale,
the instrument's full scale, the current limit -- before a run starts, and `rig selftest` checks the
configured window against the instrument's full scale.  Against a simulated bench served over Modbus TCP
on loopback (so what reached the instrument is checked at the server), and the in-process simulator."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.modbus.config import ModbusConfig
from drivers.modbus.registers import InputPoint, RegisterPoint
from rig.testing import EXACT, modbus_toml, served
from sessions import Status, read_session

from .cli import assert_one_line_error, error_lines, rig_here

pytestmark = pytest.mark.timeout(120)

QUICK = ("--levels", 4, "--dwell", 0.0, "--readings", 1)
PSD = "[modbus.psd]\naddress = 0\n"
INT16 = "[modbus.setpoint]\naddress = 0\ntype = 'int16'\nscale = 100.0\n" + PSD


@pytest.mark.parametrize("register, setpoint, max_V, edge", [
    ("float32", RegisterPoint(address=0), 1.1, float(np.nextafter(np.float32(1.1), np.float32(0)))),
    ("int16 x 100", RegisterPoint(address=0, type="int16", scale=100.0), 3.917, 3.91),
])
def test_a_window_edge_the_wire_rounds_up_runs_to_the_last_value_it_carries(tmp_path, register, setpoint, max_V,
                                                                             edge):
    extra = INT16 if register.startswith("int16") else ""
    with served(modbus=True, modbus_cfg=ModbusConfig.simulated(setpoint=setpoint), **EXACT) as bench:
        cfg = tmp_path / "rig.toml"
        cfg.write_text(modbus_toml(bench, extra=extra).replace("max_V = 6.0", f"max_V = {max_V}"))
        run = rig_here("acquire", "--config", cfg, *QUICK, "--out", tmp_path / "s.h5", "--json")
        assert run.code == 0, run.err
        s = read_session(tmp_path / "s.h5")
        assert s.status is Status.COMPLETE and s.excitation.v_max == edge and s.inputs.max() == edge
        received = bench.journal.volts_received()
        assert max(received) == edge <= max_V
        # a grid through the configured edge itself is refused before anything is applied, naming the point
        n = len(received)
        run = rig_here("acquire", "--config", cfg, *QUICK, "--v-max", max_V, "--out", tmp_path / "t.h5")
        assert_one_line_error(run, f"point 0 of the plan ({max_V:g} V)", "on the wire, which is refused")
        assert not (tmp_path / "t.h5").exists()
        assert all(v == 0.0 for v in bench.journal.volts_received()[n:])  # opening and closing: 0 V only


#: 12.78 mA through 682.5 + 100 ohm: a window up to 10.00035 V, where the simulated DAQ's full scale is 10 V.
BEYOND = """
driver = "{driver}"
[heater]
max_V = 12.0
max_current_mA = 12.78
series_resistance_ohm = 682.5
heater_resistance_ohm = 100.0
[sensor]
um_per_V = 5.0
"""


def test_a_window_beyond_the_simulators_full_scale_fails_selftest_and_is_refused_before_the_run(tmp_path):
    cfg = tmp_path / "sim.toml"
    cfg.write_text(BEYOND.format(driver="sim") + "[sim]\ntime_constant_s = 0.0\n")
    run = rig_here("selftest", "--config", cfg, "--json")
    assert run.code == 3, run.out
    report = run.json()
    assert report["window_ok"] is False and report["full_scale_V"] == 10.0 and not report["passed"]
    assert report["window_V"] == [0.0, pytest.approx(10.00035)] and "full scale of +-10 V" in report["error"]
    run = rig_here("acquire", "--config", cfg, *QUICK, "--out", tmp_path / "s.h5")
    assert_one_line_error(run, "of the plan (10.00035 V)", "full scale of +-10 V")
    assert not (tmp_path / "s.h5").exists()


def test_an_instrument_that_reports_its_full_scale_gets_nothing_beyond_it(tmp_path):
    full_scale = "[modbus.full_scale]\naddress = 4\n"
    with served(modbus=True, **EXACT) as bench:
        cfg = tmp_path / "rig.toml"
        cfg.write_text(modbus_toml(bench, extra="[modbus.setpoint]\naddress = 0\n" + PSD + full_scale)
                       .replace("max_V = 6.0", "max_V = 12.0"))
        run = rig_here("selftest", "--config", cfg, "--json")
        assert run.code == 3 and run.json()["window_ok"] is False and run.json()["full_scale_V"] == 10.0
        run = rig_here("acquire", "--config", cfg, *QUICK, "--out", tmp_path / "s.h5")
        assert_one_line_error(run, "full scale of +-10 V")
        assert not (tmp_path / "s.h5").exists()
        assert max(bench.journal.volts_received()) < 10.0


def test_an_instrument_that_refuses_a_setpoint_mid_run_is_not_followed_by_advice_to_resume(tmp_path):
    """The instrument does not say its full scale, so only its refusal reveals it: the run fails, and the
    message says the plan cannot run as configured instead of advising a --resume that fails again."""
    with served(modbus=True, **EXACT) as bench:
        cfg = tmp_path / "rig.toml"
        cfg.write_text(modbus_toml(bench).replace("max_V = 6.0", "max_V = 12.0"))
        path = tmp_path / "s.h5"
        run = rig_here("acquire", "--config", cfg, *QUICK, "--out", path)
        lines = error_lines(run.err)
        assert run.code == 3 and len(lines) == 1, run.err
        assert "Modbus exception 3" in lines[0] and "rig acquire --resume" not in lines[0]
        assert "cannot be completed on this rig as configured" in lines[0]
        assert read_session(path).status is Status.FAILED
        refused = [r for r in bench.journal.setpoints if not r.accepted]
        assert len(refused) == 1 and refused[0].volts == pytest.approx(10.00035, abs=1e-5)
