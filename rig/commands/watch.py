"""``rig watch``: follow a session live in a web browser (read-only; loopback unless asked otherwise)."""

from __future__ import annotations

import os
import signal
import socket
import sys
from pathlib import Path

import click

from identify.methods import LIVE_METHODS

from ..errors import UserError
from ..output import print_json

#: CPU priority (``nice``) of the watch: an observer, it yields the processor to the acquisition it follows.
NICE = 10
#: After this long without the awaited session appearing, say so and list the sessions that do exist (s).
NOTHING_YET_S = 3.0


def nothing_yet(target: Path) -> str:
    """The line that says a session awaited for a while has not appeared, and which ones exist there."""
    from ..watch.server import SESSION_SUFFIXES

    folder = target.parent
    there = sorted(p.name for p in folder.iterdir() if p.suffix in SESSION_SUFFIXES and not p.name.startswith("."))
    listing = ", ".join(there[:10]) + (f" and {len(there) - 10} more" if len(there) > 10 else "") if there else "none"
    return (f"rig watch: nothing has appeared at {target} after {NOTHING_YET_S:g} s (still waiting; a typo?); "
            f"sessions in {folder}: {listing}")


@click.command()
@click.argument("target", type=click.Path(path_type=Path))
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on; beyond loopback only with --allow-remote.")
@click.option("--port", type=int, default=0, show_default=True, help="Port to listen on (0: any free port).")
@click.option("--allow-remote", is_flag=True,
              help="Allow listening beyond loopback (e.g. --host 0.0.0.0); prints an access token the page requires.")
@click.option("--open", "open_browser", is_flag=True, help="Open the page in this machine's web browser.")
@click.option("--method", type=click.Choice(list(LIVE_METHODS)), default="smooth_nn", show_default=True,
              help="Method of the model so far.")
@click.option("--levels", "-L", type=int,
              help="Levels of the model's grid [the session's; 30 when it records none, over the measured inputs].")
@click.option("--refit-every", type=int, default=5, show_default=True,
              help="Re-identify the model after this many new measured points (and when the run ends).")
@click.option("--thermal-term/--no-thermal-term", default=True, show_default=True,
              help="Fit the thermal term c_d v (once the measured points can identify it).")
@click.option("--fit", "fit_path", type=click.Path(dir_okay=False, path_type=Path),
              help="The watched session is a check run: show where a model identified on this run misses on it.")
@click.option("--check", "check_path", type=click.Path(dir_okay=False, path_type=Path),
              help="The watched session is an identification run: show where its model misses on this check run "
                   "(once it exists).")
@click.option("--poll", "poll_s", type=float, default=0.25, show_default=True,
              help="Seconds between two looks at the file.")
@click.option("--json", "as_json", is_flag=True,
              help="Once listening, print one JSON object: url, host, port, token, target.")
def watch(target, host, port, allow_remote, open_browser, method, levels, refit_every, thermal_term, fit_path,
          check_path, poll_s, as_json):
    """Serve a web page that follows TARGET -- a session, or a directory of sessions to pick from -- as
    it is written (by rig acquire in another process), until Ctrl-C.  A session that does not exist yet
    is waited for.

    The page shows the status and progress, the input and output against
    time, the hysteresis loop by branch, the model so far (re-identified
    every few points on a worker process) with its residual, and, with
    --fit or --check, where the model misses on a check run. It is
    read-only: the session is only ever opened for reading, and the page can
    start, stop or change nothing.
    """
    from drivers.net import is_loopback

    from ..watch.server import Site, WatchServer, new_token
    from ..watch.tail import wait_readable

    if not target.exists() and not target.parent.is_dir():
        raise UserError(f"{target}: no such file, and no directory {target.parent} to wait for it in")
    if fit_path is not None and check_path is not None:
        raise UserError("give --fit (the watched session is a check run) or --check (it is an identification "
                        "run), not both")
    if levels is not None and levels < 1:
        raise UserError(f"--levels {levels}: must be at least 1")
    if refit_every < 1:
        raise UserError(f"--refit-every {refit_every}: must be at least 1")
    if not 0.05 <= poll_s <= 60:
        raise UserError(f"--poll {poll_s:g}: give between 0.05 and 60 seconds")
    if not 0 <= port <= 65535:
        raise UserError(f"--port {port} is out of range")
    if fit_path is not None and not fit_path.exists():
        raise UserError(f"--fit {fit_path}: no such file (the identification run must exist)")
    remote = not is_loopback(host)
    if remote and not allow_remote:
        raise UserError(f"--host {host} is not a loopback address; rig watch listens on loopback only unless "
                        "--allow-remote is given (the page then needs the access token it prints)")
    if target.is_file():
        wait_readable(target)  # a bad file is a one-line error now, not a page that never loads

    os.nice(NICE)
    from ..watch.watcher import WatchOptions, Workers

    options = WatchOptions(method=method, levels=levels, refit_every=refit_every, thermal_term=thermal_term,
                           fit=fit_path, check=check_path)
    workers = Workers.start(options)
    token = new_token() if remote else None
    site = Site(target, options, workers, poll_s)
    try:
        server = WatchServer(site, host, port, token)
    except OSError as exc:
        workers.close()
        raise UserError(f"cannot listen on {host}:{port} ({exc.strerror or exc})") from None
    shown_host = socket.gethostname() if remote and host in ("0.0.0.0", "::") else server.url_host
    url = f"http://{shown_host}:{server.port}/" + (f"?token={token}" if token else "")
    site.start()
    if as_json:
        print_json({"url": url, "host": server.server_address[0], "port": server.port, "token": token,
                    "target": str(target)})
    else:
        click.echo(url)
    sys.stdout.flush()
    what = "the sessions in" if target.is_dir() else "following"
    if not target.exists():
        what = "waiting for"
    click.echo(f"rig watch: {what} {target}, read-only; Ctrl-C to stop", err=True)
    if token:
        click.echo(f"rig watch: listening on {server.server_address[0]}:{server.port}, beyond loopback; the page "
                   f"answers only with the access token in the address above: {token} (shown now only; a new "
                   "one each start)", err=True)
    if open_browser:
        import webbrowser

        webbrowser.open(url)

    def stop(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)
    if not target.exists():
        import threading

        def still_nothing() -> None:
            if not target.exists():
                click.echo(nothing_yet(target), err=True)

        timer = threading.Timer(NOTHING_YET_S, still_nothing)
        timer.daemon = True
        timer.start()
    try:
        server.serve_forever(poll_interval=0.25)
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
        site.stop()
        workers.close()
    click.echo("rig watch: stopped", err=True)
