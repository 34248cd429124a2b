"""All ``rig`` subcommands, one module each; add new ones to :data:`COMMANDS`.

A command's module is imported only when that command runs (its imports --
numpy, scipy, h5py, pymodbus, matplotlib -- are most of a command's start-up
time), so ``rig --version``, ``rig --help`` and ``rig identify`` do not pay for
``rig serve-sim``'s or ``rig report``'s.  The one-line help that ``rig --help``
lists is therefore written here too; a test checks it against each command's
own docstring.
"""

from __future__ import annotations

import importlib
from typing import NamedTuple

import click

from ..numpy_tools import defer_numpy_tools


class CommandEntry(NamedTuple):
    """One subcommand: its name, the module that defines it, the click command's attribute, its one-line help,
    and whether it is a research command (listed after the operator's commands in ``rig --help``)."""

    name: str
    module: str
    attribute: str
    short_help: str
    research: bool = False


#: Every subcommand, alphabetical; ``rig --help`` lists the operator's commands, then the research commands.
COMMANDS: tuple[CommandEntry, ...] = (
    CommandEntry("acquire", "rig.commands.acquire", "acquire",
                 "Apply an excitation on the rig and record every point in the session OUT."),
    CommandEntry("bench", "rig.commands.bench", "bench",
                 "Time every identification method, fast path and dense reference, on simulated data.",
                 research=True),
    CommandEntry("demo", "rig.commands.demo", "demo",
                 "Acquire, identify, diagnose and report on the simulated VO2 rig, in seconds."),
    CommandEntry("diagnose", "rig.commands.diagnose", "diagnose",
                 "Diagnose the sim-to-real gap of equation (22): fit on --fit, judge on --check."),
    CommandEntry("export", "rig.commands.export", "export", "Write the samples of SESSION as a CSV trace."),
    CommandEntry("identify", "rig.commands.identify", "identify",
                 "Identify a Preisach model from each FILE: a session (HDF5) or a CSV trace (t_s,v_V,deflection_um)."),
    CommandEntry("import", "rig.commands.import_", "import_",
                 "Turn FILE (a CSV trace or a MicroMag FORC file) into the session OUT."),
    CommandEntry("invert", "rig.commands.invert", "invert",
                 "Invert the model in SOURCE for the targets in TARGET (t_s,target_um) and write the set-points to "
                 "--out."),
    CommandEntry("predict", "rig.commands.predict", "predict",
                 "Predict the output of FILE (a session or a CSV trace) with the model in MODEL_FILE."),
    CommandEntry("report", "rig.commands.report", "report",
                 "Write PNG figures and a Markdown summary of SESSION and a model stored in it."),
    CommandEntry("selftest", "rig.commands.selftest", "selftest",
                 "Connect, read the sensor, apply a small safe voltage, read it back, return to 0 V."),
    CommandEntry("serve-sim", "rig.commands.serve_sim", "serve_sim",
                 "Run the simulated device on loopback until Ctrl-C, in real time."),
    CommandEntry("study", "rig.commands.study", "study",
                 "Reproduce the paper's simulation study and print our results beside the paper's.",
                 research=True),
    CommandEntry("track", "rig.commands.track", "track",
                 "Drive the rig so that the deflection follows the targets in --target, through the inverse of the "
                 "model in SOURCE."),
    CommandEntry("validate", "rig.commands.validate", "validate",
                 "Apply the model stored in SESSION to the run given with --check and report its errors."),
    CommandEntry("watch", "rig.commands.watch", "watch",
                 "Serve a web page that follows TARGET -- a session, or a directory of sessions to pick from -- as "
                 "it is written (by rig acquire in another process), until Ctrl-C.  A session that does not exist "
                 "yet is waited for."),
)

BY_NAME: dict[str, CommandEntry] = {entry.name: entry for entry in COMMANDS}


def load(entry: CommandEntry) -> click.Command:
    """The click command of ``entry`` (imports its module, after :func:`~rig.numpy_tools.defer_numpy_tools`:
    every command imports scipy)."""
    defer_numpy_tools()
    return getattr(importlib.import_module(entry.module), entry.attribute)
