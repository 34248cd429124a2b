"""``rig serve-sim``'s listening addresses: say plainly when one is already taken.

pymodbus reports a port that is in use as "Could not start listen, please
check address"; the serial-line server as an errno.  Before any server
starts, every TCP endpoint is tried with a bind of our own (with
``SO_REUSEADDR``, as asyncio's servers bind), and a taken one is refused in
one line that names it and suggests port 0, for which the system picks a
free port and ``rig serve-sim`` prints the one it chose.
"""

from __future__ import annotations

import errno
import socket

from drivers.errors import ServeError


def in_use(host: str, port: int) -> bool:
    """Whether a TCP server could not listen on ``host:port`` because something else does."""
    if port == 0:
        return False
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror:
        return False  # not ours to judge: the server's own error says what is wrong with the name
    for family, kind, proto, _, address in infos:
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind(address)
            except OSError as exc:
                if exc.errno == errno.EADDRINUSE:
                    return True
    return False


def taken_message(option: str, host: str, port: int) -> str:
    """The one-line refusal for an address in use, with the port-0 way out."""
    scheme = "socket://" if option == "--serial" else ""
    return (f"{option} {scheme}{host}:{port}: the address is already in use (another program, perhaps "
            f"another rig serve-sim, listens there); choose a free port, or port 0 to let the system pick "
            f"one ({option} {scheme}{host}:0): serve-sim prints the port it chose, for the clients' rig.toml")


def check_free(endpoints: dict[str, tuple[str, int] | None]) -> None:
    """Refuse (:class:`ServeError`, exit 2) the first endpoint whose address is taken.

    ``endpoints`` maps the option that asked for it (``--modbus``,
    ``--modbus-rtu``, ``--serial``) to ``(host, port)``, or ``None`` when
    that endpoint is not served or is not TCP (a pseudo-terminal).
    """
    for option, where in endpoints.items():
        if where is not None and in_use(*where):
            raise ServeError(taken_message(option, *where))
