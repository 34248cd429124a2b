"""Helpers that drive the rig the way a user does, shared by the tests (``tests/``) and the benchmarks
(``benchmarks/``), so that each is written once and a benchmark imports it without editing ``sys.path``.

* the simulated bench on loopback and the ``rig.toml`` texts that point at it (:func:`served`,
  :func:`modbus_toml`, :func:`serial_toml`, :func:`config`);
* the ``rig`` command in a new process: one command run to its end (:func:`rig`), ``rig acquire`` with
  its stderr watched (:class:`Child`), and a long-running subcommand that prints a JSON line once it
  listens (:class:`Process`: :func:`serve_sim`, :func:`watch`);
* ``rig watch``'s HTTP API (:func:`get`, :func:`wait_state`) and headless Chromium (Debian's, driven by
  selenium: :func:`start_browser`, :func:`close_browser`).

Nothing here is imported by the ``rig`` command itself.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from drivers.clock import RealClock
from drivers.config import RigConfig, loads_config
from drivers.modbus.config import ModbusConfig
from drivers.serial.config import SerialConfig
from drivers.sim import SimParams, SimVO2
from drivers.sim.bench import SimBench


# ------------------------------------------------------------------ the simulated bench
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
    """``text`` read as a ``rig.toml``."""
    return loads_config(text, "test rig.toml")


# ------------------------------------------------------------------ the rig command as a process
@dataclass
class Run:
    """A finished command: its exit code, stdout and stderr."""

    code: int
    out: str
    err: str

    def json(self):
        return json.loads(self.out)


def rig_command() -> list[str]:
    """The installed ``rig`` console script of this environment (else ``python -m rig``)."""
    exe = shutil.which("rig", path=os.path.dirname(sys.executable)) or shutil.which("rig")
    return [exe] if exe else [sys.executable, "-m", "rig"]


def rig(*args, timeout: float = 120, input: str | None = None) -> Run:
    """``rig ARGS`` in a new process, run to its end (``RIG_DEBUG`` off: what a user sees)."""
    p = subprocess.run(
        [*rig_command(), *map(str, args)], capture_output=True, text=True, timeout=timeout, input=input,
        env={**os.environ, "RIG_DEBUG": ""},
    )
    return Run(p.returncode, p.stdout, p.stderr)


class Child:
    """``rig acquire ...`` in a new process; stderr is collected on a thread so the test can wait for text."""

    def __init__(self, *args, stdin=subprocess.DEVNULL) -> None:
        self.proc = subprocess.Popen(
            [*rig_command(), "acquire", *map(str, args)], stdin=stdin, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, env={**os.environ, "RIG_DEBUG": ""},
        )
        self._err = bytearray()
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        fd = self.proc.stderr.fileno()
        while chunk := os.read(fd, 4096):
            with self._lock:
                self._err += chunk

    @property
    def err(self) -> str:
        with self._lock:
            return self._err.decode("utf-8", "replace")

    def wait_for(self, text: str, timeout: float = 30.0) -> None:
        end = time.monotonic() + timeout
        while text not in self.err:
            assert self.proc.poll() is None or text in self.err, f"exited {self.proc.returncode}: {self.err}"
            assert time.monotonic() < end, f"no {text!r} on stderr: {self.err}"
            time.sleep(0.01)

    def finish(self, timeout: float = 60.0) -> tuple[int, str, str]:
        out = self.proc.stdout.read()  # not communicate(): the reader thread owns stderr
        self.proc.wait(timeout=timeout)
        self._reader.join(5)
        self.proc.stdout.close()
        self.proc.stderr.close()
        return self.proc.returncode, out.decode(), self.err

    def reported(self) -> int:
        """The last point count the progress bar showed (``k/N``)."""
        counts = re.findall(r"(\d+)/\d+ \[", self.err)
        return int(counts[-1]) if counts else 0


class Process:
    """A ``rig`` subcommand in a new process group (so a stop reaches its workers too); ``ready`` is the
    JSON line it prints once listening (read on first use, so several can start at once); stderr is
    collected on a thread."""

    def __init__(self, *args, ready_timeout: float = 30.0) -> None:
        self.subcommand = str(args[0])
        self.proc = subprocess.Popen([*rig_command(), *map(str, args)], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, start_new_session=True,
                                     env={**os.environ, "RIG_DEBUG": ""})
        self._err = bytearray()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._ready: dict | None = None
        self._ready_timeout = ready_timeout

    @property
    def ready(self) -> dict:
        if self._ready is None:
            self._ready = self._first_line(self._ready_timeout)
        return self._ready

    def _read(self) -> None:
        while chunk := os.read(self.proc.stderr.fileno(), 4096):
            self._err += chunk

    @property
    def err(self) -> str:
        return bytes(self._err).decode("utf-8", "replace")

    def _first_line(self, timeout: float) -> dict:
        fd, line, end = self.proc.stdout.fileno(), b"", time.monotonic() + timeout
        while not line.endswith(b"\n"):
            left = end - time.monotonic()
            if left <= 0 or self.proc.poll() is not None and not select.select([fd], [], [], 0)[0]:
                self.stop()
                raise AssertionError(f"{self.subcommand} printed nothing in {timeout} s: {self.err}")
            if select.select([fd], [], [], min(left, 0.1))[0]:
                chunk = os.read(fd, 1)
                if not chunk:
                    continue
                line += chunk
        return json.loads(line)

    def stop(self, sig: int = signal.SIGINT, timeout: float = 20.0) -> int:
        """Send ``sig`` (Ctrl-C by default) to the process group and wait; returns the exit code."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, sig)
        try:
            code = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            code = self.proc.wait(10)
            raise AssertionError(f"{self.subcommand} did not stop within {timeout} s: {self.err}") from None
        self._reader.join(5)
        self.proc.stdout.close()
        self.proc.stderr.close()
        return code

    def __enter__(self) -> "Process":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


#: The simulated device of the live runs: on the real clock, at rest 0.1 s after a set-point, a little noise.
SIM_TOML = HEADER.format(driver="sim") + "[sim]\ntime_constant_s = 0.002\npsd_noise_V = 0.0005\n"


def serve_sim(tmp_path: Path) -> Process:
    """``rig serve-sim`` of :data:`SIM_TOML` on a free loopback port (see :func:`client_config`)."""
    sim = tmp_path / "sim.toml"
    sim.write_text(SIM_TOML)
    return Process("serve-sim", "--config", sim, "--modbus", "127.0.0.1:0", "--json")


def client_config(server: Process, tmp_path: Path) -> Path:
    """A rig.toml whose Modbus client reaches ``server`` (waits until it listens)."""
    path = tmp_path / "rig.toml"
    path.write_text(modbus_toml(server.ready["modbus"]))
    return path


def watch(*args) -> Process:
    """``rig watch ARGS --json``: ``.ready`` holds the url, host, port and token."""
    return Process("watch", *args, "--json")


# ------------------------------------------------------------------ rig watch's HTTP API
def get(url: str, timeout: float = 10.0, headers: dict | None = None):
    """GET ``url``: (status, headers, body) -- also for error statuses."""
    req = urllib.request.Request(url, headers=headers or {})
    opener = urllib.request.build_opener(NoRedirect)
    try:
        with opener.open(req, timeout=timeout) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


class NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


def wait_state(base: str, predicate, timeout: float = 30.0, what: str = "") -> dict:
    """Poll ``base + 'api/state'`` until ``predicate(state)``; returns that state."""
    end, state = time.monotonic() + timeout, None
    while time.monotonic() < end:
        status, _, body = get(base + "api/state")
        if status == 200:
            state = json.loads(body)
            if predicate(state):
                return state
        time.sleep(0.1)
    raise AssertionError(f"no state {what} within {timeout} s; last: {state}")


# ------------------------------------------------------------------ the browser
#: Chromium's switches for the tests: headless, no sandbox (root in CI), nothing fetched, a fresh profile.
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1400,1800")
CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser")
CHROMEDRIVER = ("/usr/bin/chromedriver",)


class NoBrowser(Exception):
    """Headless Chromium cannot be driven here; the message says what is missing."""


def start_browser():
    """A headless Chromium driven by selenium, or :class:`NoBrowser` saying what is missing."""
    exe = next((p for p in CHROMIUM if os.access(p, os.X_OK)), None)
    driver = next((p for p in CHROMEDRIVER if os.access(p, os.X_OK)), None)
    if exe is None or driver is None:
        raise NoBrowser("no Chromium: install Debian's chromium and chromium-driver to run the browser tests")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        raise NoBrowser("selenium is not installed (pip install -e '.[test]')") from None
    os.environ.setdefault("SE_OFFLINE", "true")  # selenium's manager must never fetch a driver or a browser
    options = webdriver.ChromeOptions()
    options.binary_location = exe
    profile = tempfile.mkdtemp(prefix="rig-watch-chromium-")
    for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):
        options.add_argument(flag)
    drv = webdriver.Chrome(service=Service(driver), options=options)
    drv.set_page_load_timeout(30)
    drv.profile_dir = profile
    return drv


def close_browser(drv) -> None:
    """Quit the browser ``drv`` and remove its profile."""
    try:
        drv.quit()
    finally:
        shutil.rmtree(drv.profile_dir, ignore_errors=True)
