"""Plug-ins by name: a fixed tuple of classes, looked up where it is used.

The effects (:data:`identify.effects.EFFECT_CLASSES`), the identification
methods (:data:`identify.methods.METHOD_CLASSES`) and the simulated
device's effects (:data:`drivers.sim.builtin_effects.SIM_EFFECT_CLASSES`)
are each listed once, as a tuple of classes that carry their own knowledge
(a ``name`` and what the rest of the program asks of them).  Adding one is
its own module and one line in that tuple.

:class:`ByName` is the tuple seen by name.  It reads the tuple at every
use, so whatever is built from it -- the command line's choices and help,
the study's methods, the budget, the inverse -- follows the tuple, also
when a test extends it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any, TypeVar

T = TypeVar("T")


class ByName(Mapping[str, T]):
    """The classes ``classes()`` returns, by their ``name``, in the tuple's order."""

    def __init__(self, classes: Callable[[], tuple[Any, ...]]) -> None:
        self._classes = classes

    def __getitem__(self, name: str) -> T:
        for cls in self._classes():
            if cls.name == name:
                return cls
        raise KeyError(name)

    def __iter__(self) -> Iterator[str]:
        return (cls.name for cls in self._classes())

    def __len__(self) -> int:
        return len(self._classes())

    def __repr__(self) -> str:
        return f"ByName({', '.join(self)})"
