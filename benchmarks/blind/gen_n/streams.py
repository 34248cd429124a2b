"""Independent random streams: one per (seed, run, purpose), so no draw depends on another.

A stream is keyed by the session seed, the run's index and a purpose string (a
mechanism's name, ``"noise"``, ``"timing"``...).  A run's streams therefore do not
change when runs are appended after it, when the strength changes, or when other
mechanisms are present.
"""

from __future__ import annotations

import zlib

import numpy as np

_TAG = 0x6E_0B_1A_7D  # this generator's own namespace


def key(text: str) -> int:
    """A stable 32-bit code of ``text`` (not Python's salted ``hash``)."""
    return zlib.crc32(text.encode("utf-8"))


def stream(seed: int, run: int, purpose: str) -> np.random.Generator:
    """The generator for ``purpose`` in run ``run`` of the session seeded by ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([_TAG, int(seed) & 0xFFFF_FFFF, int(run), key(purpose)]))


def loguniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def sign(rng: np.random.Generator, p_plus: float = 0.5) -> int:
    return 1 if rng.uniform() < p_plus else -1
