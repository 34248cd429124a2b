"""Run the ``rig`` command as a user would: in this process (:func:`rig_here`), ``rig serve-sim`` in its own,
and the checks of a one-line error.  A command in a new process is :func:`rig.testing.rig`."""

from __future__ import annotations

import json
import signal
import subprocess

from rig.testing import Run, rig_command


def error_lines(err: str) -> list[str]:
    """The non-empty stderr lines but the plan ``rig acquire`` states before it starts (``plan: ...``),
    which is information, not part of an error."""
    return [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("plan: ")]


def assert_one_line_error(run: Run, *fragments: str) -> None:
    """Exit 2, a single stderr line, no traceback, naming the problem."""
    assert run.code == 2, (run.code, run.err)
    lines = error_lines(run.err)
    assert "Traceback" not in run.err
    assert len(lines) == 1, run.err
    for f in fragments:
        assert f.lower() in lines[0].lower(), (f, lines[0])


class _EntryPoint:
    """``rig.cli.main`` in the shape CliRunner invokes: the console script's own error handling."""

    name = "rig"

    def main(self, args, prog_name=None, **_):
        from rig.cli import main

        main(list(args))


def rig_here(*args, input: str | None = None) -> Run:
    """Run a rig command in this process, through the console script's entry point: the same
    streams, messages and exit codes, without the start-up time of a new interpreter (for tests
    of what a command says and does; the process itself -- signals, start-up -- needs :func:`rig`)."""
    from click.testing import CliRunner

    result = CliRunner().invoke(_EntryPoint(), [str(a) for a in args], input=input, catch_exceptions=False,
                                env={"RIG_DEBUG": ""})
    return Run(result.exit_code, result.stdout, result.stderr)


def serve_sim(*args, cwd=None):
    """Start ``rig serve-sim ARGS --json`` in its own process; ``(process, endpoints)`` once it listens."""
    proc = subprocess.Popen(
        [*rig_command(), "serve-sim", *map(str, args), "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, cwd=cwd,
    )
    line = proc.stdout.readline()
    if not line:
        proc.wait(10)
        raise AssertionError(proc.stderr.read())
    return proc, json.loads(line)


def stop(proc):
    """Ctrl-C a ``serve_sim`` process; its exit code and stderr."""
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=20)
    return proc.returncode, err
