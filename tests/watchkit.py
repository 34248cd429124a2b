"""Helpers for the ``rig watch`` tests beside :mod:`rig.testing` (the served device, ``rig watch`` as a process,
the page's HTTP API, headless Chromium): the descriptors a process holds on a session, and the page as the
browser shows it (the browser tests skip without Debian's Chromium)."""

from __future__ import annotations

import os
import time
from pathlib import Path

from rig.testing import NoBrowser, start_browser


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


def browser_or_skip():
    """:func:`start_browser`, or ``pytest.skip`` with the reason."""
    import pytest

    try:
        return start_browser()
    except NoBrowser as exc:
        pytest.skip(str(exc))


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
