"""One name per idea across the ``rig`` commands, and today's old spellings still accepted (hidden).

``-o/--out`` for what a command writes, ``--check`` for the held-out run, ``--with`` for effects,
``-M/--measurements`` for the measured count, ``--force`` only to replace files, ``--yes`` only to
pass limits, durations in seconds without a unit suffix; ``rig`` alone prints the help and exits 0.
The table is ``docs/reference/cli-names.md``; this checks it, row by row.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rig.commands import BY_NAME, COMMANDS, load
from rig.options import AliasedOption

from .cli import rig_here
from .forcfiles import REPO

#: (command, arguments it needs besides the option, current name, old spelling, parameter, value given, parsed).
RENAMED = [
    ("identify", ["s.h5"], "--out", "--save", "save", "m.json", Path("m.json")),
    ("identify", ["s.h5"], "-o", "--save", "save", "m.json", Path("m.json")),
    ("export", ["s.h5"], "--out", "--csv", "csv_out", "t.csv", Path("t.csv")),
    ("export", ["s.h5"], "-o", "--csv", "csv_out", "t.csv", Path("t.csv")),
    ("study", [], "--out", "--plots", "plots", "figs", Path("figs")),
    ("study", [], "-o", "--plots", "plots", "figs", Path("figs")),
    ("diagnose", ["--fit", "a.h5", "--check", "b.h5"], "-o", "--out", "out_dir", "d", Path("d")),
    ("validate", ["s.h5"], "--check", "--on", "run", "v.h5", Path("v.h5")),
    ("report", ["s.h5"], "--check", "--validate", "validation", "v.h5", Path("v.h5")),
    ("diagnose", ["--fit", "a.h5", "--check", "b.h5"], "--with", "--effects", "effects", "creep,reversible",
     ("creep,reversible",)),
    ("demo", [], "--with", "--effect", "effect", "joule_power", "joule_power"),
    ("acquire", [], "--measurements", "--measure", "measure", "100", 100),
    ("acquire", [], "-M", "--measure", "measure", "100", 100),
    ("bench", [], "--budget", "--budget-s", "budget_s", "5", 5.0),
    ("bench", [], "--timeout", "--timeout-s", "timeout_s", "60", 60.0),
]


def parsed(command: str, args: list[str]) -> dict:
    cmd = load(BY_NAME[command])
    with cmd.make_context(f"rig {command}", list(args), resilient_parsing=False) as ctx:
        return ctx.params


def help_options(command: str) -> set[str]:
    """Every option name ``rig COMMAND --help`` shows."""
    text = rig_here(command, "--help").out
    return set(re.findall(r"(?<![\w-])(--?[a-zA-Z][\w-]*)", text.split("Options:")[1]))


@pytest.mark.parametrize("command, needs, name, old, param, value, expected", RENAMED)
def test_the_new_name_and_the_old_spelling_set_the_same_option(command, needs, name, old, param, value, expected):
    assert parsed(command, [*needs, name, value])[param] == expected
    assert parsed(command, [*needs, old, value])[param] == expected
    shown = help_options(command)
    assert name in shown, (command, name)
    if old not in {"--out"}:  # diagnose --out only gained -o
        assert old not in shown, (command, old)  # accepted, never shown


def test_no_old_spelling_shows_in_any_help_or_error():
    for entry in COMMANDS:
        cmd = load(entry)
        shown = help_options(entry.name)
        for param in cmd.params:
            if isinstance(param, AliasedOption):
                assert param.aliases and not set(param.aliases) & shown, (entry.name, param.aliases)
                assert not set(param.aliases) & set(param.opts)  # the reference (sphinx-click) reads opts
                assert not set(param.aliases) & set(re.findall(r"'([^']+)'", param.get_error_hint(None)))


def test_what_a_command_writes_is_out_everywhere():
    writers = {"acquire", "demo", "diagnose", "export", "identify", "import", "invert", "report", "study", "track"}
    for name in writers:
        opts = {o for p in load(BY_NAME[name]).params for o in p.opts}
        assert {"-o", "--out"} <= opts, name
    for entry in COMMANDS:  # and no other option name for it
        opts = {o for p in load(entry).params for o in p.opts}
        assert not opts & {"--save", "--csv", "--plots", "--output", "--out-dir"}, entry.name


def test_force_only_replaces_files_and_yes_only_passes_limits():
    for entry in COMMANDS:
        for p in load(entry).params:
            if "--force" in p.opts:
                assert p.help.startswith("Replace"), (entry.name, p.help)
            if "--yes" in p.opts:
                assert "limits" in p.help and "Replace" not in p.help, (entry.name, p.help)


def test_durations_are_seconds_named_without_a_unit_suffix():
    for entry in COMMANDS:
        for p in load(entry).params:
            for opt in p.opts:
                assert not re.search(r"-(s|ms|sec|secs|seconds)$", opt), (entry.name, opt)


def test_rig_alone_prints_the_help_and_exits_0():
    alone, asked = rig_here(), rig_here("--help")
    assert alone.code == 0 and asked.code == 0
    assert alone.out == asked.out and alone.err == ""
    assert alone.out.startswith("Usage: rig") and "\n\nCommands:\n" in alone.out


def test_the_names_table_in_the_docs_lists_every_renamed_option():
    table = (REPO / "docs" / "reference" / "cli-names.md").read_text(encoding="utf-8")
    for command, _, name, old, *_ in RENAMED:
        assert re.search(rf"`rig {command}`.*`{re.escape(old)}`", table), (command, old)


def test_new_names_run_end_to_end(tmp_path):
    s, v = tmp_path / "s.h5", tmp_path / "v.h5"
    assert rig_here("acquire", "-L", "5", "--dwell", "1", "--measurements", "12", "-o", s, "--no-progress").code == 0
    assert rig_here("acquire", "--sequence", "random", "--points", "10", "--dwell", "1", "-o", v,
                    "--no-progress").code == 0
    assert rig_here("identify", s, "-o", tmp_path / "m.json").code == 0 and (tmp_path / "m.json").is_file()
    assert rig_here("validate", s, "--check", v, "--json").json()["on"] == str(v)
    assert rig_here("export", v, "-o", tmp_path / "v.csv").code == 0 and (tmp_path / "v.csv").is_file()
    done = rig_here("report", s, "--check", v, "-o", tmp_path / "rep", "--json")
    assert done.code == 0 and done.json()["validation"]["on"] == str(v)
