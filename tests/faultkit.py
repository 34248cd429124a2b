"""Helpers for the fault-injection tests: ``rig serve-sim`` as a real process on loopback, with its
journal file (what the heater saw), that a test can kill, stop, continue and restart on the same port.

Every wait is bounded in time; every process is reaped.  Also :func:`sensor_dies_after`, the same PSD
fault for a run in this process."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from drivers.sim.journal import read_journal
from rig.acquisition import Hooks
from rig.testing import FAST_LINK, HEADER

#: The device of the fault tests: on the real clock, exactly at rest after 0.1 s, without noise.
FAST_SIM = "[sim]\ntime_constant_s = 0.002\npsd_noise_V = 0.0\nlevels = 8\n"

#: The register map served and used (the simulated bench's default, with its restart marker).
FAULT_MAP = "[modbus.setpoint]\naddress = 0\n[modbus.psd]\naddress = 0\n"


def sensor_dies_after(rig, index: int) -> Hooks:
    """Hooks for ``acquire``/``resume`` on an in-process simulated ``rig``: once point ``index`` is recorded
    the PSD reads NaN (for the next 100 readings), so the run stops with ``SensorError`` right after it."""
    def inject(result):
        if result.index == index:
            rig.device.faults.nan_readings = 100

    return Hooks(on_sample=inject)


def rig_exe() -> str:
    return shutil.which("rig", path=os.path.dirname(sys.executable)) or "rig"


class SimServer:
    """``rig serve-sim --modbus 127.0.0.1:PORT --journal FILE`` in its own process."""

    def __init__(self, workdir: Path, name: str = "server", port: int = 0, register_map: str = FAULT_MAP,
                 sim: str = FAST_SIM) -> None:
        self.workdir = Path(workdir)
        self.name = name
        self.register_map = register_map
        self.sim = sim
        self.journal_path = self.workdir / f"{name}.journal"
        self.generation = 0
        self.port = port
        self.proc: subprocess.Popen | None = None
        self._start()

    def _start(self) -> None:
        self.generation += 1
        cfg = self.workdir / f"{self.name}-serve.toml"
        cfg.write_text(HEADER.format(driver="modbus") + "[modbus]\n" + self.register_map + self.sim)
        journal = self.journal_file(self.generation)
        self.proc = subprocess.Popen(
            [rig_exe(), "serve-sim", "--config", str(cfg), "--modbus", f"127.0.0.1:{self.port}",
             "--journal", str(journal), "--json"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        line = self.proc.stdout.readline()
        if not line:
            self.proc.wait(10)
            raise AssertionError(f"serve-sim did not start: {self.proc.stderr.read()}")
        self.endpoint = json.loads(line)["modbus"]
        self.port = int(self.endpoint.rsplit(":", 1)[1])

    def journal_file(self, generation: int) -> Path:
        return self.journal_path.with_suffix(f".{generation}.journal")

    def client_toml(self, timeout: float = 0.3, retries: int = 1, extra: str = "", port: int | None = None) -> str:
        """rig.toml for ``rig acquire`` against this server (or against ``port``: a proxy in front of it)."""
        return (HEADER.format(driver="modbus") + f'[modbus]\nhost = "127.0.0.1"\nport = {port or self.port}\n'
                + FAST_LINK.format(timeout=timeout, retries=retries) + extra + self.register_map)

    def client_config(self, path: Path, **kw) -> Path:
        path.write_text(self.client_toml(**kw))
        return path

    # ------------------------------------------------------------ faults
    def kill(self) -> None:
        """SIGKILL: the instrument dies holding its output; its connections are reset."""
        self._signal(signal.SIGKILL)
        self._reap()

    def stop(self) -> None:
        """SIGSTOP: the instrument hangs (the kernel still accepts connections; nothing answers)."""
        self._signal(signal.SIGSTOP)

    def cont(self) -> None:
        self._signal(signal.SIGCONT)

    def restart(self) -> None:
        """A new server on the same port: a fresh device (0 V, negative saturation, a new boot)."""
        if self.proc is not None and self.proc.poll() is None:
            self.kill()
        self._start()

    def close(self) -> int | None:
        """Stop with SIGINT (as an operator would); returns the exit code."""
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self._signal(signal.SIGCONT)
            self._signal(signal.SIGINT)
        code = self._reap()
        self.proc = None
        return code

    def _signal(self, sig: int) -> None:
        assert self.proc is not None
        if self.proc.poll() is None:
            os.kill(self.proc.pid, sig)

    def _reap(self) -> int:
        assert self.proc is not None
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(20)
        for stream in (self.proc.stdout, self.proc.stderr):
            stream.close()
        return self.proc.returncode

    # ------------------------------------------------------------ what the heater saw
    def setpoints(self, generation: int | None = None) -> list[dict]:
        """Set-point requests received by server ``generation`` (default: the current one)."""
        path = self.journal_file(generation or self.generation)
        return [e for e in read_journal(path) if e["event"] == "setpoint"]

    def accepted_volts(self, generation: int | None = None) -> list[float]:
        return [e["volts"] for e in self.setpoints(generation) if e["accepted"]]

    def events(self, generation: int | None = None) -> list[dict]:
        return read_journal(self.journal_file(generation or self.generation))

    def __enter__(self) -> "SimServer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def wait_until(condition, timeout: float, what: str, step: float = 0.01) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, f"timed out after {timeout} s waiting for {what}"
        time.sleep(step)
