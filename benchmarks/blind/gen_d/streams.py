"""Random streams of the realisation: one independent stream per (seed, purpose, run).

Every random choice of a realisation (a drift's path, a step's time, the noise) is
drawn from its own stream, keyed only by the session's seed and a fixed tag of
its purpose, never by the strength or by the other mechanisms present.
"""

from __future__ import annotations

import numpy as np

_SALT = 0x6E2D_0D17

#: Fixed tags of the streams (never renumber: they define the realisations).
TAGS = {
    "noise": 1,
    "baseline_drift": 2,
    "gain_drift": 3,
    "ambient_drift": 4,
}


def stream(seed: int, purpose: str, *keys: int) -> np.random.Generator:
    """An independent generator for ``purpose`` (see ``TAGS``) of the session ``seed``."""
    entropy = [_SALT, int(seed) & 0xFFFF_FFFF_FFFF_FFFF, TAGS[purpose], *(int(k) for k in keys)]
    return np.random.default_rng(np.random.SeedSequence(entropy))
