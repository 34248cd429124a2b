"""Helpers for the ``rig acquire`` process tests: a served simulated bench, a child ``rig acquire``
whose stderr is watched, a pseudo-terminal for its stdin, and a spy on the device's set-points."""

from __future__ import annotations

import os
import pty
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

from sessions import DataFileError, read_session

from .benchsim import modbus_toml

#: A device on the real clock that is exactly at rest after 0.1 s (50 time constants), without noise.
FAST_DEVICE = dict(time_constant_s=0.002, psd_noise_V=0.0)


def virtual_sim_config(tmp_path: Path, levels: int, time_constant_s: float, name: str = "rig.toml") -> Path:
    """A ``rig.toml`` of the in-process simulated device on the virtual clock: L = ``levels`` on 0-6 V,
    first-order lag ``time_constant_s`` (s)."""
    path = tmp_path / name
    path.write_text(f"""driver = "sim"
clock = "virtual"
[heater]
max_V = 6.0
[sensor]
um_per_V = 5.0
[sim]
levels = {levels}
time_constant_s = {time_constant_s}
""")
    return path


def refused_before_writing(config: Path, tmp_path: Path, args: list[str], message: str) -> None:
    """``rig acquire --config CONFIG --out NEW ARGS`` is one line naming ``message``, exit 2, and no file."""
    from .cli import assert_one_line_error, rig_here

    out = tmp_path / "refused.h5"
    assert_one_line_error(rig_here("acquire", "--config", config, "--out", out, *args), message)
    assert not out.exists()


def bench_config(bench, tmp_path: Path, name: str = "rig.toml") -> Path:
    path = tmp_path / name
    path.write_text(modbus_toml(bench))
    return path


class Child:
    """``rig acquire ...`` in a new process; stderr is collected on a thread so the test can wait for text."""

    def __init__(self, *args, stdin=subprocess.DEVNULL) -> None:
        exe = shutil.which("rig", path=os.path.dirname(sys.executable)) or shutil.which("rig")
        self.proc = subprocess.Popen(
            [exe, "acquire", *map(str, args)], stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            env={**os.environ, "RIG_DEBUG": ""},
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


def wait_for_samples(path: Path, n: int, timeout: float = 30.0, child: Child | None = None) -> int:
    """Poll the session another process is writing until it holds ``n`` samples; returns the count."""
    end = time.monotonic() + timeout
    while True:
        try:
            count = read_session(path).n_samples
            if count >= n:
                return count
        except DataFileError:  # not created yet, or its layout is being written
            pass
        if child is not None:
            assert child.proc.poll() is None, f"the run ended early: {child.err}"
        assert time.monotonic() < end, f"fewer than {n} samples in {path} after {timeout} s"
        time.sleep(0.005)


class Terminal:
    """A pseudo-terminal: the child's stdin is a TTY; the test types on the master side."""

    def __init__(self) -> None:
        self.master, self.slave = pty.openpty()

    def type(self, text: str) -> None:
        os.write(self.master, text.encode())

    def close(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


class SetpointSpy:
    """Records the device's state just before every set-point it accepts (the final memory state of a
    run is the state before the heater goes back to 0 V)."""

    def __init__(self, device) -> None:
        self.device = device
        self.writes: list[tuple[float, object]] = []
        original = device.apply_voltage

        def spy(volts):
            self.writes.append((float(volts), device.state()))
            original(volts)

        device.apply_voltage = spy

    def state_at_end(self):
        """The state when the last non-zero set-point was left for 0 V."""
        last = max(i for i, (v, _) in enumerate(self.writes) if v != 0.0)
        assert self.writes[last + 1][0] == 0.0
        return self.writes[last + 1][1]
