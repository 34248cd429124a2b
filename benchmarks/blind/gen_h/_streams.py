"""Random streams of the simulator: every stream is keyed, never shared in sequence.

* ``effect_stream(seed, name, run)``: the realisation of mechanism ``name`` in run ``run``
  (a drift's path...), from the seed and the name only -- not from the strength, nor from
  the other mechanisms present.
* ``timing_stream(seed, run)`` / ``noise_stream(seed, run)``: the lab's timing and the
  measurement noise of one run, each from a stream of its own (prefix stability: a run does
  not depend on how many runs follow it).
"""

from __future__ import annotations

import zlib

import numpy as np

_TAG = 0x6E_48_B1  # this generator's own tag, so its streams differ from anybody else's

_KIND = {"effect": 1, "timing": 2, "noise": 3, "static": 4}


def _name_key(name: str) -> int:
    return zlib.crc32(name.encode("utf-8")) & 0xFFFF_FFFF


def _seed_key(seed: int) -> int:
    return int(seed) % (1 << 63)


def effect_stream(seed: int, name: str, run: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(
        [_TAG, _KIND["effect"], _seed_key(seed), _name_key(name), int(run)]))


def static_stream(seed: int, name: str) -> np.random.Generator:
    """A mechanism's session-wide realisation (not per run)."""
    return np.random.default_rng(np.random.SeedSequence(
        [_TAG, _KIND["static"], _seed_key(seed), _name_key(name)]))


def timing_stream(seed: int, run: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([_TAG, _KIND["timing"], _seed_key(seed), int(run)]))


def noise_stream(seed: int, run: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([_TAG, _KIND["noise"], _seed_key(seed), int(run)]))
