"""The ``rig`` command: subcommands live one per module in :mod:`rig.commands`.

Errors about the user's input print one line and exit with code 2; faults
of the instrument or its link print one line and exit with code 3 (see
:mod:`rig.errors`); an unexpected exception prints one line and exits 1
(set ``RIG_DEBUG=1`` for the traceback).
"""

from __future__ import annotations

import os
import sys

import click

from .commands import BY_NAME, load
from .errors import RigFault, UserError, is_rig_fault, is_user_error

#: What click >= 8.2 raises for a bare ``rig`` (8.1 printed the help and exited 0 by itself).
NO_ARGS = getattr(click.exceptions, "NoArgsIsHelpError", ())


class RigGroup(click.Group):
    """A click group that turns domain errors into one-line messages.

    Its subcommands are those of :data:`rig.commands.COMMANDS`, each imported
    only when it runs (see :mod:`rig.commands`); commands added with
    :meth:`add_command` (tests) come first.
    """

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*self.commands, *BY_NAME})

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name in self.commands:
            return self.commands[name]
        entry = BY_NAME.get(name)
        return None if entry is None else load(entry)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """``rig --help``'s command lists, from the registry's one-line help (no command is imported):
        the operator's commands, then the research commands (``bench``, ``study``)."""
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(name) for name in names)  # as click.Group does
        sections: dict[str, list[tuple[str, str]]] = {"Commands": [], "Research commands": []}
        for name in names:
            if name in self.commands:
                row = (name, self.commands[name].get_short_help_str(limit))
            else:
                row = (name, click.Command(name, help=BY_NAME[name].short_help).get_short_help_str(limit))
            research = name in BY_NAME and BY_NAME[name].research
            sections["Research commands" if research else "Commands"].append(row)
        for title, rows in sections.items():
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort, KeyboardInterrupt, SystemExit):
            raise
        except Exception as exc:
            if is_user_error(exc):
                raise UserError(str(exc)) from None
            if is_rig_fault(exc):
                raise RigFault(str(exc)) from None
            # a bug: keep it to one line unless debugging
            if os.environ.get("RIG_DEBUG"):
                raise
            click.echo(
                f"rig: internal error: {type(exc).__name__}: {exc} (set RIG_DEBUG=1 for details)",
                err=True,
            )
            sys.exit(1)


@click.group(cls=RigGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vo2rig", prog_name="rig")
def cli() -> None:
    """Preisach hysteresis identification for the VO2 microactuator rig."""


def main(args: list[str] | None = None) -> None:
    """Console entry point (``args``: the arguments, default ``sys.argv[1:]``): every error is one
    line on stderr; always ends with :class:`SystemExit` carrying the exit code.  ``rig`` with no
    arguments prints the help, as ``rig --help`` does, and exits 0."""
    try:
        code = cli.main(args=args, prog_name="rig", standalone_mode=False)
    except NO_ARGS as exc:  # a request for help, not an error
        click.echo(exc.ctx.get_help(), color=exc.ctx.color)
        sys.exit(0)
    except click.UsageError as exc:
        hint = f" (see '{exc.ctx.command_path} --help')" if exc.ctx is not None else ""
        click.echo(f"Error: {' '.join(exc.format_message().split())}{hint}", err=True)
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        click.echo(f"Error: {' '.join(exc.format_message().split())}", err=True)
        sys.exit(exc.exit_code)
    except (click.Abort, KeyboardInterrupt):
        click.echo("Error: interrupted", err=True)
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)
