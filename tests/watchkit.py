"""Helpers for the ``rig watch`` tests: the served simulated device, ``rig watch`` as a process, the page's
HTTP API, and headless Chromium (Debian's, driven by selenium; the browser tests skip without it)."""

from __future__ import annotations

import json
import os
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
from pathlib import Path

from .benchsim import HEADER, modbus_toml

#: The simulated device of the live runs: on the real clock, at rest 0.1 s after a set-point, a little noise.
SIM_TOML = HEADER.format(driver="sim") + "[sim]\ntime_constant_s = 0.002\npsd_noise_V = 0.0005\n"
#: Chromium's switches for the tests: headless, no sandbox (root in CI), nothing fetched, a fresh profile.
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1400,1800")
CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser")
CHROMEDRIVER = ("/usr/bin/chromedriver",)


def rig_exe() -> str:
    return shutil.which("rig", path=os.path.dirname(sys.executable)) or shutil.which("rig") or "rig"


class Process:
    """A ``rig`` subcommand in a new process group (so a stop reaches its workers too); ``ready`` is the
    JSON line it prints once listening (read on first use, so several can start at once); stderr is
    collected on a thread."""

    def __init__(self, *args, ready_timeout: float = 30.0) -> None:
        self.proc = subprocess.Popen([rig_exe(), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     stdin=subprocess.DEVNULL, start_new_session=True,
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
                raise AssertionError(f"{self.proc.args[1]} printed nothing in {timeout} s: {self.err}")
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
            raise AssertionError(f"{self.proc.args[1]} did not stop within {timeout} s: {self.err}") from None
        self._reader.join(5)
        self.proc.stdout.close()
        self.proc.stderr.close()
        return code

    def __enter__(self) -> "Process":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def serve_sim(tmp_path: Path) -> Process:
    """``rig serve-sim`` of :data:`SIM_TOML` on a free loopback port (see :func:`client_config`)."""
    sim = tmp_path / "sim.toml"
    sim.write_text(SIM_TOML)
    return Process("serve-sim", "--config", sim, "--modbus", "127.0.0.1:0", "--json")


def client_config(server: Process, tmp_path: Path) -> Path:
    """A rig.toml whose Modbus client reaches ``server`` (waits until it listens)."""
    config = tmp_path / "rig.toml"
    config.write_text(modbus_toml(server.ready["modbus"]))
    return config


def watch(*args) -> Process:
    """``rig watch ARGS --json``: ``.ready`` holds the url, host, port and token."""
    return Process("watch", *args, "--json")


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


def session_fds(pid: int, path: Path) -> list[int]:
    """The access modes (``os.O_RDONLY``, ...) of every descriptor process ``pid`` holds on ``path``."""
    modes, target = [], os.path.realpath(path)
    fd_dir = Path(f"/proc/{pid}/fd")
    for fd in fd_dir.iterdir():
        try:
            if os.path.realpath(os.readlink(fd)) != target:
                continue
            flags = next(ln for ln in (fd_dir.parent / "fdinfo" / fd.name).read_text().splitlines()
                         if ln.startswith("flags:"))
        except OSError:
            continue
        modes.append(int(flags.split()[1], 8) & os.O_ACCMODE)
    return modes


# ------------------------------------------------------------------ the browser
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


def browser_or_skip():
    """:func:`start_browser`, or ``pytest.skip`` with the reason."""
    import pytest

    try:
        return start_browser()
    except NoBrowser as exc:
        pytest.skip(str(exc))


def close_browser(drv) -> None:
    try:
        drv.quit()
    finally:
        shutil.rmtree(drv.profile_dir, ignore_errors=True)


def wait_page(drv, predicate, timeout: float = 30.0, what: str = ""):
    """Evaluate ``predicate(drv)`` until it is truthy (bounded); returns its value."""
    end, last = time.monotonic() + timeout, None
    while time.monotonic() < end:
        try:
            last = predicate(drv)
        except Exception as exc:  # an element not there yet
            last = exc
        else:
            if last:
                return last
        time.sleep(0.1)
    raise AssertionError(f"the page never showed {what} within {timeout} s (last: {last!r})")


def svg_texts(drv, figure: str) -> list[str]:
    """The text a person reads on figure ``figure`` of the page (axis labels, ticks, legend, title)."""
    return drv.execute_script(
        "const box = document.querySelector(`[data-figure='${arguments[0]}'] svg`);"
        "return box ? Array.from(box.querySelectorAll('text')).map(t => t.textContent.trim()) : [];", figure)
