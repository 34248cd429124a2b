"""The copy-pasteable ``sh`` blocks of a documentation page, run as a reader would paste them."""

from __future__ import annotations

import re
import shlex

from rig.testing import rig_command

BLOCK = re.compile(r"^```sh\n(.*?)^```", re.M | re.S)


def sh_lines(text: str) -> list[str]:
    """Every command line of the ``sh`` blocks of ``text``, in order (comments and blank lines dropped)."""
    lines = []
    for block in BLOCK.findall(text):
        lines += [ln.strip() for ln in block.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    return lines


def argv(line: str) -> list[str]:
    """``line`` as a process's arguments, ``rig`` being this environment's console script."""
    words = shlex.split(line, comments=True)
    return [*rig_command(), *words[1:]] if words[0] == "rig" else words
