"""Interoperability with an independent Modbus implementation: libmodbus (Debian's ``libmodbus-dev``, 3.1.6)
and its ``mbpoll`` client.  Every other Modbus test has pymodbus on both ends, so a bug both ends share --
a word order, a register offset, a scale -- could not show there.

* ``mbpoll`` writes and reads the simulated bench (``rig serve-sim``, and the same server on a thread);
* a small libmodbus server (``tests/interop/modbus_server.c``, compiled here; it decodes the set-point
  with libmodbus's own float getters -- its 3.1.6 setters swap the bytes of each word, libmodbus issue
  #611, which is the kind of shared-assumption bug these tests exist to catch) is the instrument the
  ``modbus`` driver talks to;

over float32 and scaled-integer register maps in both word orders.  Skipped, saying why, where the tools
are missing; ``.ci/run`` installs them on Debian."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from drivers import open_rig
from drivers.modbus.config import ModbusConfig
from drivers.modbus.registers import InputPoint, RegisterPoint
from rig.testing import EXACT, FAST_LINK, HEADER, config, served

from .faultkit import FAST_SIM, SimServer

pytestmark = pytest.mark.timeout(120)

#: (type, word order, scale): float32 and scaled integers, both word orders.
MAPS = [("float32", "big", 1.0), ("float32", "little", 1.0), ("int32", "big", 1000.0),
        ("int32", "little", 1000.0), ("int16", "big", 100.0)]

needs_mbpoll = pytest.mark.skipif(shutil.which("mbpoll") is None,
                                  reason="mbpoll is not installed (Debian package mbpoll; .ci/run installs it)")


def mbpoll(port: int, table: int, kind: str, order: str, *values) -> subprocess.CompletedProcess:
    """One mbpoll transaction on 127.0.0.1:port: reference 0 (PDU addressing), unit 1, once."""
    suffix = {"float32": ":float", "int32": ":int", "int16": ""}[kind]
    args = ["mbpoll", "-m", "tcp", "-a", "1", "-0", "-r", "0", "-1", "-p", str(port), "-t", f"{table}{suffix}"]
    if order == "big" and kind != "int16":
        args.append("-B")
    return subprocess.run([*args, "127.0.0.1", *map(str, values)], capture_output=True, text=True, timeout=30)


def polled(run: subprocess.CompletedProcess) -> float:
    values = re.findall(r"^\[0\]:\s+(\S+)", run.stdout, re.M)
    assert run.returncode == 0 and values, (run.stdout, run.stderr)
    return float(values[0])


def raw(kind: str, scale: float, volts: float) -> str:
    return f"{volts * scale:g}" if kind == "float32" else str(round(volts * scale))


@needs_mbpoll
@pytest.mark.parametrize("kind, order, scale", MAPS)
def test_mbpoll_drives_and_reads_the_simulated_bench(kind, order, scale):
    point = dict(address=0, type=kind, scale=scale, word_order=order)
    cfg = ModbusConfig.simulated(setpoint=RegisterPoint(**point), psd=InputPoint(**point))
    with served(modbus=True, modbus_cfg=cfg, **EXACT) as bench:
        port = int(bench.endpoints["modbus"].rsplit(":", 1)[1])
        assert "Written 1 references" in mbpoll(port, 4, kind, order, raw(kind, scale, 2.5)).stdout
        assert bench.journal.setpoints[-1].accepted and bench.journal.volts_received()[-1] == 2.5
        assert bench.device.applied_voltage == 2.5
        assert polled(mbpoll(port, 4, kind, order)) == float(raw(kind, scale, 2.5))
        psd = bench.device.true_model().predict([2.5])[0] / 5.0  # the bench's PSD: 5 um/V, no noise
        word = polled(mbpoll(port, 3, kind, order))
        if kind == "int16" and word >= 2**15:  # mbpoll shows a 16-bit register unsigned
            word -= 2**16
        got = word / scale
        assert got == pytest.approx(psd, rel=1e-5, abs=0.51 / scale if kind != "float32" else 0)
        # a value beyond the simulated DAQ's 10 V full scale: refused with exception 3, never applied
        refused = mbpoll(port, 4, kind, order, raw(kind, scale, 11.0))
        assert "Illegal data value" in refused.stdout + refused.stderr, (refused.stdout, refused.stderr)
        assert not bench.journal.setpoints[-1].accepted and bench.journal.volts_received()[-1] == 11.0
        assert bench.device.applied_voltage == 2.5


@needs_mbpoll
def test_mbpoll_against_a_rig_serve_sim_process(tmp_path):
    with SimServer(tmp_path, register_map="[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n",
                   sim=FAST_SIM.replace("time_constant_s = 0.002", "time_constant_s = 0.0")) as server:
        assert "Written 1 references" in mbpoll(server.port, 4, "float32", "big", 3.25).stdout
        assert polled(mbpoll(server.port, 4, "float32", "big")) == 3.25
        assert -25 < polled(mbpoll(server.port, 3, "float32", "big")) * 5 < 25  # a deflection in um
        assert server.accepted_volts() == [3.25]


@pytest.fixture(scope="module")
def libmodbus_server(tmp_path_factory) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    header = Path("/usr/include/modbus/modbus.h")
    if cc is None or not header.exists():
        pytest.skip("a C compiler and libmodbus-dev are needed for the libmodbus instrument (.ci/run installs them)")
    exe = tmp_path_factory.mktemp("libmodbus") / "modbus_server"
    source = Path(__file__).with_name("interop") / "modbus_server.c"
    done = subprocess.run([cc, "-O1", "-Wall", "-o", str(exe), str(source), f"-I{header.parent}", "-lmodbus", "-lm"],
                          capture_output=True, text=True, timeout=120)
    if done.returncode != 0:
        pytest.skip(f"cannot build the libmodbus instrument: {done.stderr.strip()[:300]}")
    return exe


@pytest.mark.parametrize("kind, order, scale", MAPS)
def test_the_modbus_driver_drives_a_libmodbus_instrument(libmodbus_server, kind, order, scale):
    proc = subprocess.Popen([str(libmodbus_server), kind, order, str(scale)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = int(proc.stdout.readline().split()[1])
        table = f"address = 0\ntype = '{kind}'\nscale = {scale}\nword_order = '{order}'\n"
        toml = (HEADER.format(driver="modbus") + f'[modbus]\nhost = "127.0.0.1"\nport = {port}\n'
                + FAST_LINK.format(timeout=1.0, retries=2) + "[modbus.setpoint]\n" + table + "[modbus.psd]\n" + table)
        sent = []
        with open_rig(config(toml)) as rig:
            for v in (1.25, 3.5, 0.75, 4.1234):
                rig.heater.set_voltage(v)
                sent.append(rig.heater.last_written)
                assert rig.heater.read_voltage() == sent[-1]
                step = 0 if kind == "float32" else 1 / scale
                assert rig.sensor.read().psd_V == pytest.approx(0.25 * sent[-1] - 1.0, rel=1e-6, abs=step / 2 + 1e-9)
        proc.stdin.close()  # the instrument stops at the end of its input
        proc.wait(30)
        out, err = proc.stdout.read(), proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        for stream in (proc.stdout, proc.stderr):
            stream.close()
    seen = [float(x) for x in re.findall(r"^SET (\S+)$", out, re.M)]
    # what the instrument decoded with libmodbus: 0 V on opening, each set-point as rounded on the wire, 0 V
    assert seen == pytest.approx([0.0, *sent, 0.0], rel=1e-7, abs=1e-12), (out, err)
    if kind != "float32":
        assert sent[-1] == round(4.1234 * scale) / scale
    else:
        assert sent[-1] == float(np.float32(4.1234))
