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
        address = ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return False
    mapped = getattr(address, "ipv4_mapped", None)  # ::ffff:127.0.0.1 is 127.0.0.1
    return address.is_loopback or (mapped is not None and mapped.is_loopback)
