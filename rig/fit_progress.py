"""A status line for a long fit (or ``rig demo``): what it is doing, how long it has run, about how long is left.

``identify`` stays pure: :func:`identify.fit.fit_sequence` only calls the
``progress`` callback it is given with the stage it starts.  This module is
that callback's other end: on a terminal, a line on stderr redrawn twice a
second -- ``rig identify: s.h5: fitting, 12 s, about 30 s left`` -- where the
time left is the estimate (:mod:`rig.budget.identification`) minus the time
spent, and says so when the fit runs over it.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import TextIO

from .budget.limits import format_duration

#: Seconds between redraws.
REDRAW_S = 0.5


class FitProgress:
    """``with FitProgress(label, estimate_s) as shown: fit(..., progress=shown.stage)``.

    Draws only when ``enabled`` (default: when ``stream`` is a terminal); the
    line is erased when the block ends.
    """

    def __init__(self, label: str, estimate_s: float, stream: TextIO | None = None,
                 enabled: bool | None = None) -> None:
        self.label = label
        self.estimate_s = float(estimate_s)
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.stage_name = "starting"
        self._start = time.monotonic()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()  # the fit's callback and the redrawing thread both draw
        self._width = 0

    def stage(self, name: str) -> None:
        """The progress callback: the fit has started stage ``name``."""
        self.stage_name = name
        self._draw()

    def line(self, now: float | None = None) -> str:
        """The status line at time ``now`` (``time.monotonic()``)."""
        spent = (time.monotonic() if now is None else now) - self._start
        left = self.estimate_s - spent
        when = f"about {format_duration(left)} left" if left > 0 else "taking longer than estimated"
        elapsed = f"{spent:.1f} s" if spent < 60 else format_duration(spent)
        return f"{self.label}: {self.stage_name}, {elapsed}, {when}"

    def _draw(self) -> None:
        if not self.enabled:
            return
        with self._lock:
            text = self.line()
            self.stream.write("\r" + text.ljust(self._width))
            self.stream.flush()
            self._width = len(text)

    def _run(self) -> None:
        while not self._stop.wait(REDRAW_S):
            self._draw()

    def __enter__(self) -> "FitProgress":
        self._start = time.monotonic()
        if self.enabled:
            self._thread = threading.Thread(target=self._run, name="fit-progress", daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        with self._lock:
            if self.enabled and self._width:
                self.stream.write("\r" + " " * self._width + "\r")
                self.stream.flush()
            self._width = 0


def fit_in_process(fit, jobs: list, costs: list, labels: list[str], enabled: bool | None = None) -> list:
    """``[fit(job, progress=...) for job in jobs]`` in this process, a :class:`FitProgress` line on the
    fits estimated (``costs[k].seconds``) to take longer than ``PROGRESS_AFTER_S``."""
    from .budget.identification import PROGRESS_AFTER_S

    reports = []
    for job, cost, label in zip(jobs, costs, labels):
        if cost.seconds <= PROGRESS_AFTER_S:
            reports.append(fit(job))
            continue
        with FitProgress(label, cost.seconds, enabled=enabled) as shown:
            reports.append(fit(job, progress=shown.stage))
    return reports
