"""rig.toml: every key documented, unknown or missing keys rejected by name, cross-checks."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from drivers import ConfigError, load_config, loads_config
from drivers.config import RigConfig, default_config
from drivers.configschema import describe
from drivers.sim import SimParams

ROOT = Path(__file__).resolve().parents[1]

MINIMAL = """
driver = "sim"
[heater]
max_V = 6.0
[sensor]
um_per_V = 5.0
"""


def test_the_documented_example_loads_with_the_values_it_shows():
    cfg = load_config(ROOT / "docs" / "rig.toml")
    assert cfg.driver == "modbus" and cfg.clock_kind == "real"
    assert cfg.heater.limits().window.max_V == 6.0
    assert cfg.modbus.setpoint.describe() == "holding[0] float32 x1 (big word order)"
    assert cfg.modbus.psd.table == "input"
    assert cfg.serial.commands.format_set(1.25) == "SOUR:VOLT 1.250000"
    assert cfg.sim == SimParams()
    assert cfg.source.endswith("rig.toml")


def test_every_key_is_documented_in_the_reference_and_the_example():
    # the reference page is generated from the schema (docs/_ext/rigdocs.py): every key, with its own words
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    try:
        from rigdocs import config_tables
    finally:
        sys.path.remove(str(ROOT / "docs" / "_ext"))
    assert "```{rig-toml-reference}" in (ROOT / "docs" / "reference" / "rig-toml.md").read_text(encoding="utf-8")
    example = (ROOT / "docs" / "rig.toml").read_text(encoding="utf-8")
    described = describe(RigConfig)
    keys = [d["key"] for d in described]
    assert len(keys) > 60
    documented = {k.key: k for t in config_tables() for k in t.keys}
    missing = [k for k in keys if k not in documented]
    assert not missing, f"the rig.toml reference lacks {missing}"
    assert not [d["key"] for d in described if not d["doc"] or not documented[d["key"]].meaning.startswith(d["doc"])]
    assert {t.name for t in config_tables()} >= {"", "heater", "sensor", "modbus", "modbus.setpoint", "modbus.psd",
                                                 "modbus.boot_id", "modbus.full_scale", "serial", "serial.commands",
                                                 "sim"}
    leaf_names = {k.rsplit(".", 1)[-1] for k in keys}
    assert not [n for n in leaf_names if not re.search(rf"^(#? ?{n} =|\[[\w.]*\b{n}\])", example, re.M)]
    # the example names the simulator's built-in effects, all of them (it once said there were none)
    from drivers.sim import EFFECTS

    effects_comment = example.split("[sim.effects]")[1]
    assert all(name in effects_comment for name in EFFECTS), list(EFFECTS)


def test_minimal_config_fills_defaults():
    cfg = loads_config(MINIMAL)
    assert cfg.clock_kind == "virtual"
    assert cfg.heater.min_V == 0.0 and cfg.heater.max_current_mA is None
    assert cfg.sensor.calibration().to_um(1.0) == 5.0
    assert cfg.to_dict()["sim"]["levels"] == 30


@pytest.mark.parametrize(
    "text, fragment",
    [
        (MINIMAL + "max_v = 1\n", "unknown key 'sensor.max_v'"),
        (MINIMAL.replace("[heater]", "[heatr]"), "unknown key 'heatr'"),
        (MINIMAL.replace("max_V = 6.0", "max_v = 6.0"), "unknown key 'heater.max_v' in [heater] (did you mean 'heater.max_V'?)"),
        (MINIMAL.replace("um_per_V = 5.0", ""), "missing required key 'sensor.um_per_V'"),
        (MINIMAL.replace('driver = "sim"', ""), "missing required key 'driver'"),
        (MINIMAL.replace("[heater]\nmax_V = 6.0\n", ""), "missing required key 'heater'"),
        (MINIMAL.replace('"sim"', '"gpib"'), "key 'driver' must be one of"),
        (MINIMAL.replace("6.0", '"6"'), "key 'heater.max_V' must be a number"),
        (MINIMAL.replace("6.0", "nan"), "key 'heater.max_V' must be finite"),
        (MINIMAL + "[sim]\nlevels = 2.5\n", "key 'sim.levels' must be an integer"),
        (MINIMAL + "[sim]\ntime_constant_s = -1.0\n", "key 'sim.time_constant_s' must be >= 0"),
        (MINIMAL + "[sim.effects]\nwarp = 0.1\n", "unknown effect 'sim.effects.warp'"),
        (MINIMAL + "[sim.effects.creep]\nstrength = 0.1\ngain = 2.0\n", "unknown key 'sim.effects.creep.gain'"),
        (MINIMAL.replace('"sim"', '"modbus"'), "needs a [modbus] table"),
        (MINIMAL + "[heater.extra]\n", "unknown key 'heater.extra'"),
        (MINIMAL.replace("max_V = 6.0", "max_V = 6.0\nmax_current_mA = 12.78"), "needs series_resistance_ohm"),
        (MINIMAL.replace("max_V = 6.0", "max_V = 6.0\nmin_V = 1.0"), "min_V <= 0"),
        (MINIMAL.replace("max_V = 6.0", "max_V = 0.2"), "selftest_V"),
        ('clock = "virtual"\n' + MINIMAL.replace('"sim"', '"serial"') + '[serial]\nurl = "loop://"\n',
         "only for driver = 'sim'"),
        (MINIMAL + "[modbus]\nport = 99999\n", "key 'modbus.port' must be <= 65535"),
        (MINIMAL + "[modbus]\n[modbus.setpoint]\naddress = 0\n", "missing required key 'modbus.psd'"),
        (MINIMAL + "[modbus]\n[modbus.setpoint]\naddress = 0\ntype = 'real'\n[modbus.psd]\naddress = 4\n",
         "key 'modbus.setpoint.type' must be one of"),
        (MINIMAL + "[modbus]\n[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 1\ntable = 'holding'\n",
         "overlap"),
        (MINIMAL + "[modbus]\n[modbus.setpoint]\naddress = 0\ntable = 'input'\n[modbus.psd]\naddress = 4\n",
         "must be a holding register"),
        (MINIMAL + "[modbus]\ntransport = 'rtu'\n[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n",
         "needs url"),
        (MINIMAL + "[serial]\nurl = 'loop://'\n[serial.commands]\nset_voltage = 'VOLT'\n", "must contain '{volts}'"),
        (MINIMAL + "[serial]\nurl = 'loop://'\n[serial.commands]\nset_voltage = 'VOLT {v}'\n", "set_voltage"),
        ("driver = 'sim'\n[heater\n", "not valid TOML"),
    ],
)
def test_bad_configs_are_rejected_naming_the_key(text, fragment):
    with pytest.raises(ConfigError) as info:
        loads_config(text, "rig.toml")
    assert fragment in str(info.value)
    assert str(info.value).startswith("rig.toml: ")


def test_to_dict_is_a_valid_configuration_again():
    from drivers.config import parse_config

    cfg = load_config(ROOT / "docs" / "rig.toml")
    data = cfg.to_dict()
    assert "source" not in data and data["modbus"]["psd"]["table"] == "input"
    assert parse_config(data) == cfg
    assert parse_config(default_config().to_dict()) == default_config()


def test_serve_sim_listens_where_the_config_connects():
    from drivers.sim.bench import endpoints_from_config

    cfg = load_config(ROOT / "docs" / "rig.toml")
    assert endpoints_from_config(cfg.modbus, cfg.serial) == {"modbus": "127.0.0.1:5020", "serial": "socket://127.0.0.1:5021"}
    rtu = loads_config(MINIMAL + "[modbus]\ntransport = 'rtu'\nurl = 'socket://127.0.0.1:7000'\n"
                       "[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n"
                       "[serial]\nurl = '/dev/ttyUSB0'\n")
    assert endpoints_from_config(rtu.modbus, rtu.serial) == {"modbus_rtu": "127.0.0.1:7000"}
    assert endpoints_from_config(None, None) == {}


def test_a_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_config(tmp_path / "rig.toml")


def test_default_config_is_the_simulated_bench_with_the_papers_current_limit():
    cfg = default_config()
    assert cfg.driver == "sim" and cfg.clock_kind == "virtual"
    assert cfg.heater.max_current_mA == 12.78
    assert cfg.heater.limits().window.max_V == 6.0  # the voltage range binds before 10.0 V of current
    assert cfg.sensor.um_per_V == cfg.sim.psd_um_per_V
