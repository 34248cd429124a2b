"""The operator's view of a run: a tqdm progress bar on stderr, and the pause prompt.

The bar counts applied points (``k/N``), with elapsed time and ETA, and
shows how many were measured and the rig-clock time of the run (virtual on
the simulated device).  :func:`terminal_prompt` is the pause decision of
``rig acquire``: on a terminal it asks "resume or abort"; without one
(stdin not a TTY: scripts, CI, ``nohup``) nobody can answer, so a Ctrl-C
(SIGINT) stops the run at the next safe point as an abort -- the session
keeps every sample and can be continued with ``--resume``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import TextIO

from tqdm import tqdm

from ..budget.limits import format_duration
from .engine import PointResult
from .interrupt import Decision, PauseInfo


class ProgressBar:
    """tqdm on ``stream`` (stderr); :meth:`update` per recorded point, :meth:`clear` before printing."""

    def __init__(self, total: int, initial: int = 0, stream: TextIO | None = None, enabled: bool = True) -> None:
        self._bar = tqdm(
            total=total, initial=initial, unit="pt", desc="acquire", file=stream or sys.stderr,
            disable=not enabled, dynamic_ncols=True, mininterval=0.2, smoothing=0.05,
        )
        self._measured = 0

    def update(self, result: PointResult) -> None:
        self._measured += result.measured
        self._bar.set_postfix_str(f"measured {self._measured}, rig time {format_duration(result.t_s)}", refresh=False)
        self._bar.update(1)

    def clear(self) -> None:
        self._bar.clear()

    def refresh(self) -> None:
        self._bar.refresh()

    def close(self) -> None:
        self._bar.close()


def terminal_prompt(bar: ProgressBar | None = None, stdin: TextIO | None = None,
                    stream: TextIO | None = None) -> Callable[[PauseInfo], Decision]:
    """The pause decision: ask on the terminal; ``"abort"`` when stdin is not one (see the module doc)."""
    stdin = stdin or sys.stdin
    stream = stream or sys.stderr

    def decide(info: PauseInfo) -> Decision:
        if bar is not None:
            bar.clear()
        where = f"point {info.index} of {info.n_points}"
        if not stdin.isatty():
            print(f"Interrupted at {where}: no terminal to ask, so stopping here (abort).", file=stream, flush=True)
            return "abort"
        held = f"heater held at {info.setpoint_V:g} V" if info.setpoint_V == info.setpoint_V else "heater at 0 V"
        print(f"Paused at {where} ({info.phase}); {held}.", file=stream, flush=True)
        while True:
            print("[r]esume or [a]bort? (Ctrl-C aborts) ", end="", file=stream, flush=True)
            answer = stdin.readline()
            if not answer:  # end of input: nobody to ask any more
                print("", file=stream, flush=True)
                return "abort"
            answer = answer.strip().lower()
            if answer in ("r", "resume", "c", "continue"):
                if bar is not None:
                    bar.refresh()
                return "resume"
            if answer in ("a", "abort", "q", "quit"):
                return "abort"

    return decide
