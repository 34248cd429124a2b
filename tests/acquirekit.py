"""Helpers for the ``rig acquire`` process tests beside :mod:`rig.testing` (the served simulated bench, a child
``rig acquire`` whose stderr is watched): a session's samples as another process writes them, a
pseudo-terminal for the child's stdin, and a spy on the device's set-points."""

from __future__ import annotations

import os
import pty
import time
from pathlib import Path

from rig.testing import Child, modbus_toml
from sessions import DataFileError, read_session

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
