"""Independent, reproducible random streams keyed by purpose.

Every random choice of a realisation comes from the session ``seed`` through a
stream of its own, keyed by what it is for (the noise of run 2, the timing of
run 0, the drift path of the first ``baseline_drift`` entry in run 1, ...).
Streams never share a sequence, so a run's draws do not depend on how many runs
follow it, on the strengths, or on which other mechanisms are present.
"""

from __future__ import annotations

import zlib

import numpy as np

#: A tag that separates this generator's streams from any other use of the seed.
_TAG = 0x6E4D_B11D


def _word(key: object) -> int:
    """A stable non-negative integer for a key (str hashed with CRC-32, never Python's ``hash``)."""
    if isinstance(key, str):
        return zlib.crc32(key.encode("utf-8"))
    return int(key) % (1 << 64)


def stream(seed: int, *keys: object) -> np.random.Generator:
    """A generator for ``(seed, *keys)``: same keys, same draws; different keys, independent draws."""
    words = [_TAG, int(seed) % (1 << 64)] + [_word(k) for k in keys]
    return np.random.default_rng(np.random.SeedSequence(words))
