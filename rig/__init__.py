"""The ``rig`` application: the only package that talks to the user."""

from __future__ import annotations


def __getattr__(name: str) -> str:
    # ``rig.__version__`` is looked up on first use: importlib.metadata costs every command
    # about 15 ms of start-up, and only ``rig --version`` and the session writer need it.
    if name != "__version__":
        raise AttributeError(f"module 'rig' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("vo2rig")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        value = "0+unknown"
    globals()["__version__"] = value
    return value
