"""The web server of ``rig watch``: the standard library's threaded HTTP server, read-only, local by default.

Routes (every one a GET; anything else is refused with 405 -- the page can
start, stop or change nothing):

* one session: ``/`` the page, ``/api/state`` its state (``?after=V``
  waits up to ``wait`` seconds, at most 25, for a version newer than V: a
  long poll), ``/figure/NAME.svg`` (``time``, ``loop``, ``model``, ``where``);
* a directory: ``/`` the list of its sessions, ``/api/sessions`` the same
  as JSON, and each session's page and API under ``/s/FILE/``;
* ``/static/...``: the page's script and style sheet (package data).

Access.  On loopback (the default) requests must name a loopback host in
their ``Host`` header, so a web page elsewhere cannot reach the server
through DNS rebinding.  Bound beyond loopback (``--allow-remote``) every
request needs the access token printed at start: ``?token=`` once (it is
then kept in a same-site, HTTP-only cookie and dropped from the address),
or the cookie.
"""

from __future__ import annotations

import hmac
import json
import secrets
import socket
import sys
import threading
import time
from http import HTTPStatus
from http.cookies import SimpleCookie
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qs, quote, unquote, urlsplit

from drivers.net import is_loopback

from .tail import session_summary
from .watcher import SessionWatch, WatchOptions, Workers

#: Cookie that carries the access token after the first visit.
COOKIE = "rig_watch_token"
#: Longest long poll a page may ask for (s).
MAX_WAIT_S = 25.0
#: How often a busy worker is asked for its result (s): a finished figure is published this soon.
WORKER_CHECK_S = 0.02
#: A directory's session not looked at for this long is closed (s).
IDLE_CLOSE_S = 600.0
#: Files of a directory listed as sessions.
SESSION_SUFFIXES = (".h5", ".hdf5", ".he5")
#: Static files of the page, by URL name: (package file, content type).
STATIC = {"watch.js": "text/javascript; charset=utf-8", "watch.css": "text/css; charset=utf-8"}
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; "
                               "script-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
}


def asset(name: str) -> bytes:
    """A file of the page (``rig/watch/page/``)."""
    return resources.files("rig.watch").joinpath("page", name).read_bytes()


class Site:
    """What is served: one session, or the sessions of a directory; and the thread that keeps them current.

    The publishing thread steps every open :class:`SessionWatch`: it reads
    the files every ``poll_s`` seconds (sooner when a page arrives), and
    between those looks collects what the workers finished -- a fit, a
    diagnosis, a figure -- as soon as it is ready.
    """

    def __init__(self, target: Path, options: WatchOptions, workers: Workers, poll_s: float = 0.25) -> None:
        self.target = Path(target)
        self.directory = self.target.is_dir()
        self.options = options
        self.workers = workers
        self.poll_s = poll_s
        self.watches: dict[str, SessionWatch] = {}
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rig-watch-publisher", daemon=True)
        self._summaries: dict[str, tuple[tuple, dict]] = {}
        if not self.directory:
            self.watches[self.target.name] = SessionWatch(self.target, options, workers)

    def start(self) -> "Site":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(10)
        for w in list(self.watches.values()):
            w.tail.close()

    def wake(self) -> None:
        self._wake.set()

    def _run(self) -> None:
        next_poll = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            poll = now >= next_poll
            if poll:
                next_poll = now + self.poll_s
            with self._lock:
                watches = list(self.watches.items())
            for name, w in watches:
                if self._stop.is_set():
                    return
                try:
                    w.step(poll_file=poll)
                except Exception as exc:  # keep serving; the page shows the error
                    w.tail.error = f"internal error: {type(exc).__name__}: {exc}"
                if self.directory and time.monotonic() - w.viewed_at > IDLE_CLOSE_S:
                    with self._lock:
                        self.watches.pop(name, None)
                    w.tail.close()
            # while a worker is busy, look for its result often; else sleep until the next poll of the files
            wait = WORKER_CHECK_S if self.workers.busy else next_poll - time.monotonic()
            self._wake.wait(max(0.0, min(wait, next_poll - time.monotonic())))
            self._wake.clear()

    # ------------------------------------------------------------------ sessions
    def session_files(self) -> list[Path]:
        """The directory's session files, newest first (hidden files, such as a rewrite's copy, left out)."""
        files = [p for p in self.target.iterdir()
                 if p.suffix.lower() in SESSION_SUFFIXES and not p.name.startswith(".") and p.is_file()]
        return sorted(files, key=lambda p: p.stat().st_mtime, reverse=True)

    def watch(self, name: str) -> SessionWatch | None:
        """The watch of session ``name`` (a file directly in the directory), opened on first use."""
        with self._lock:
            w = self.watches.get(name)
        if w is not None:
            return w
        if not self.directory or name not in {p.name for p in self.session_files()}:
            return None
        with self._lock:
            w = self.watches.setdefault(name, SessionWatch(self.target / name, self.options, self.workers))
        w.viewed_at = time.monotonic()
        self.wake()
        return w

    def listing(self) -> list[dict]:
        """The directory's sessions for the index: name, status and counts, modification time."""
        out = []
        for p in self.session_files():
            st = p.stat()
            key = (st.st_size, st.st_mtime_ns, st.st_ino)
            cached = self._summaries.get(p.name)
            if cached is None or cached[0] != key:
                cached = (key, session_summary(p))
                self._summaries[p.name] = cached
            out.append({"name": p.name, "modified_unix": st.st_mtime, **cached[1]})
        return out


class WatchServer(ThreadingHTTPServer):
    """The HTTP server of a :class:`Site`; ``token`` is the access token (None on loopback, where the
    ``Host`` check applies instead)."""

    daemon_threads = True
    allow_reuse_address = True
    #: The listen queue: a burst of a few hundred simultaneous requests (a page reloaded in many tabs, a
    #: scripted poll) is answered, not dropped by the kernel to be retried seconds later (the default is 5).
    request_queue_size = 1024

    def __init__(self, site: Site, host: str, port: int, token: str | None) -> None:
        self.site = site
        self.token = token
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        self.address_family = infos[0][0]
        super().__init__(infos[0][4][:2], WatchHandler)
        self.loopback_only = token is None
        self.port = self.server_address[1]

    def handle_error(self, request, client_address) -> None:
        """A page closed or a client gave up mid-answer: nothing to report.  Anything else is a bug, on one line."""
        exc = sys.exc_info()[1]
        if isinstance(exc, (BrokenPipeError, ConnectionResetError, TimeoutError)):
            return
        print(f"rig watch: internal error answering {client_address[0]}: {type(exc).__name__}: {exc}",
              file=sys.stderr)

    @property
    def url_host(self) -> str:
        host = self.server_address[0]
        return f"[{host}]" if ":" in host else host


def new_token() -> str:
    """A fresh access token: 128 random bits, URL-safe."""
    return secrets.token_urlsafe(16)


class WatchHandler(BaseHTTPRequestHandler):
    """Serves the :class:`Site` of its :class:`WatchServer`; GET and HEAD only."""

    server: WatchServer
    protocol_version = "HTTP/1.1"
    server_version = "rig-watch"

    # ------------------------------------------------------------------ plumbing
    def log_message(self, format, *args) -> None:  # noqa: A002 - the base class's name
        pass  # the terminal is the operator's; requests are not news

    def _send(self, status: int, body: bytes, ctype: str, headers: dict[str, str] | None = None) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        for k, v in {**SECURITY_HEADERS, **(headers or {})}.items():
            self.send_header(k, v)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _text(self, status: int, message: str) -> None:
        self._send(status, (message + "\n").encode(), "text/plain; charset=utf-8")

    def _json(self, obj, headers: dict[str, str] | None = None) -> None:
        self._send(HTTPStatus.OK, json.dumps(obj).encode(), "application/json", headers)

    def _refuse(self) -> None:
        self._text(HTTPStatus.METHOD_NOT_ALLOWED, "rig watch is a read-only view: only GET is served")

    do_POST = do_PUT = do_DELETE = do_PATCH = _refuse

    def do_HEAD(self) -> None:
        self.do_GET()

    # ------------------------------------------------------------------ access
    def _host_ok(self) -> bool:
        if not self.server.loopback_only:
            return True
        hosts = self.headers.get_all("Host") or []
        host = (hosts[0] if len(hosts) == 1 else "").strip()
        if host.startswith("["):
            name = host[: host.find("]") + 1]
        else:
            name = host.rsplit(":", 1)[0]
        return is_loopback(name)

    def _token_ok(self, query: dict[str, list[str]]) -> tuple[bool, bool]:
        """(allowed, came in the query)."""
        token = self.server.token
        if token is None:
            return True, False
        given = query.get("token", [None])[0]
        if given is not None and hmac.compare_digest(given.encode(), token.encode()):
            return True, True
        cookie = SimpleCookie(self.headers.get("Cookie") or "")
        if COOKIE in cookie and hmac.compare_digest(cookie[COOKIE].value.encode(), token.encode()):
            return True, False
        return False, False

    # ------------------------------------------------------------------ routes
    def do_GET(self) -> None:
        url = urlsplit(self.path)
        query = parse_qs(url.query)
        if len(self.headers.get_all("Host") or []) > 1:
            return self._text(HTTPStatus.BAD_REQUEST, "a request names one Host (RFC 9112, section 3.2)")
        if not self._host_ok():
            return self._text(HTTPStatus.FORBIDDEN, "rig watch answers only requests addressed to this machine's "
                                                    "loopback interface (127.0.0.1, localhost)")
        allowed, in_query = self._token_ok(query)
        if not allowed:
            return self._send(HTTPStatus.FORBIDDEN, asset("forbidden.html"), "text/html; charset=utf-8")
        if in_query:  # keep the token in a cookie, and out of the address bar and the history
            cookie = f"{COOKIE}={self.server.token}; HttpOnly; SameSite=Strict; Path=/"
            return self._send(HTTPStatus.SEE_OTHER, b"", "text/plain", {"Location": url.path or "/",
                                                                          "Set-Cookie": cookie})
        path = unquote(url.path)
        site = self.server.site
        if path.startswith("/static/"):
            name = path.removeprefix("/static/")
            if name not in STATIC:
                return self._text(HTTPStatus.NOT_FOUND, "no such file")
            return self._send(HTTPStatus.OK, asset(name), STATIC[name])
        if path == "/favicon.ico":
            return self._send(HTTPStatus.NO_CONTENT, b"", "image/x-icon")
        if site.directory:
            if path == "/":
                return self._send(HTTPStatus.OK, asset("index.html"), "text/html; charset=utf-8")
            if path == "/api/sessions":
                return self._json({"directory": str(site.target), "sessions": site.listing()})
            if path.startswith("/s/"):
                name, sep, rest = path.removeprefix("/s/").partition("/")
                watch = site.watch(name)
                if watch is None:
                    return self._text(HTTPStatus.NOT_FOUND, f"no session {name!r} in {site.target}")
                if not sep:
                    return self._send(HTTPStatus.MOVED_PERMANENTLY, b"", "text/plain",
                                      {"Location": f"/s/{quote(name)}/"})
                return self._session(watch, "/" + rest, query)
            return self._text(HTTPStatus.NOT_FOUND, "not found")
        return self._session(site.watches[site.target.name], path, query)

    def _session(self, watch: SessionWatch, path: str, query: dict[str, list[str]]) -> None:
        if path == "/":
            return self._send(HTTPStatus.OK, asset("watch.html"), "text/html; charset=utf-8")
        if path == "/api/state":
            try:
                after = int(query["after"][0]) if "after" in query else None
                wait = min(MAX_WAIT_S, max(0.0, float(query.get("wait", ["0"])[0])))
            except ValueError:
                return self._text(HTTPStatus.BAD_REQUEST, "after must be a whole number and wait a number")
            if watch.look():
                self.server.site.wake()  # a first look: draw now rather than at the next poll
            _, body = watch.state_json(after, wait)
            return self._send(HTTPStatus.OK, body, "application/json")
        if path.startswith("/figure/") and path.endswith(".svg"):
            fig = watch.figure(path.removeprefix("/figure/").removesuffix(".svg"))
            if fig is None:
                return self._text(HTTPStatus.NOT_FOUND, "this figure has not been drawn yet")
            return self._send(HTTPStatus.OK, fig[1], "image/svg+xml", {"X-Figure-Version": str(fig[0])})
        return self._text(HTTPStatus.NOT_FOUND, "not found")
