"""One name per idea on the ``rig`` command line, and the old spellings each renamed option still accepts.

The names (``docs/reference/cli-names.md`` has the table):

* ``-o/--out`` -- whatever a command writes, a file or a directory;
* ``--check`` -- the held-out run a model is judged on;
* ``--with`` -- unmodelled effects;
* ``-M/--measurements`` -- how many points are measured or fitted;
* ``--force`` -- replace an existing file (or a stored model); ``--yes`` -- go past a documented limit;
* durations in seconds, named without a unit suffix (``--dwell``, ``--poll``, ``--budget``, ``--timeout``).

An option renamed for this keeps its old spelling as a hidden alias (:class:`AliasedOption`), so no
script breaks: the alias is accepted on the command line and shown nowhere -- not in ``--help``, not
in error messages, not in the generated command reference.
"""

from __future__ import annotations

from typing import Any, Sequence

import click


class AliasedOption(click.Option):
    """A click option that also accepts ``aliases``, its old spellings, without ever showing them.

    ``opts`` holds the current names only (help, error messages and sphinx-click read it); the
    aliases are added for parsing alone.  Use as ``@click.option("--out", "-o", "save",
    cls=AliasedOption, aliases=("--save",), ...)``.
    """

    def __init__(self, param_decls: Sequence[str] | None = None, aliases: Sequence[str] = (), **attrs: Any):
        super().__init__(param_decls, **attrs)
        self.aliases = tuple(aliases)
        for alias in self.aliases:
            if not alias.startswith("-") or alias in self.opts:
                raise ValueError(f"{alias!r}: an alias is another option name of {self.name!r}")

    def add_to_parser(self, parser, ctx: click.Context) -> None:
        shown = self.opts
        self.opts = [*shown, *self.aliases]
        try:
            super().add_to_parser(parser, ctx)
        finally:
            self.opts = shown


def scheduler_option(command: Any) -> Any:
    """``--scheduler ADDRESS``: run a command's parallel jobs on a dask.distributed cluster
    (:mod:`rig.parallel`) instead of on local processes."""
    return click.option(
        "--scheduler", metavar="ADDRESS",
        help="Run the jobs on the dask.distributed cluster whose scheduler is at ADDRESS (tcp://HOST:PORT; "
             "needs the [cluster] extra here and on the workers) instead of on local processes; "
             "the results are the same.",
    )(command)
