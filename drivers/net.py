"""Network addresses: whether a host is this machine's loopback interface.

Servers of this package (``rig serve-sim``, ``rig watch``) listen on
loopback unless the user explicitly allows more; they decide with
:func:`is_loopback`.
"""

from __future__ import annotations

import ipaddress


def is_loopback(host: str) -> bool:
    """Whether ``host`` -- a name or an address, IPv6 possibly in brackets -- is the loopback interface."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False
