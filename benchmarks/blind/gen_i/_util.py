"""Small helpers: random streams, JSON-safe forms, reference scales of a device, the Preisach cell map."""

from __future__ import annotations

import dataclasses
import zlib
from functools import lru_cache

import numpy as np

from .. import base

#: Entropy tag of this generator's streams (keeps them apart from other users of the same seed).
_TAG = 0x6E1_B1D


def name_key(name: str) -> int:
    """A stable (process-independent) integer for a name."""
    return int(zlib.crc32(name.encode("utf-8")))


def stream(seed: int, run: int, name: str, *extra: int) -> np.random.Generator:
    """The random stream of ``name`` in run ``run`` of the session seeded ``seed``.

    Every run and every purpose has a stream of its own, so a run's realisation depends neither
    on how many runs follow it nor on which other mechanisms are present.
    """
    entropy = [_TAG, int(seed) % (1 << 64), int(run), name_key(name), *[int(e) for e in extra]]
    return np.random.default_rng(np.random.SeedSequence(entropy))


def loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def pick(rng: np.random.Generator, options, p=None):
    i = int(rng.choice(len(options), p=p))
    return options[i]


def json_safe(obj):
    """Plain Python containers and scalars only."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj)
    if obj is None or isinstance(obj, str):
        return obj
    raise TypeError(f"not JSON-safe: {type(obj)}")


@dataclasses.dataclass(frozen=True, eq=False)
class Reference:
    """Scales of one device, from its clean major loop (used to set the size of strength 1)."""

    swing_um: float          # max - min of the clean major loop's output
    u_min_um: float
    u_max_um: float
    phase_half_um: float     # P: phase runs from -P to +P
    slope_max_um_per_V: float  # steepest d(phase)/dx on the major loop
    rise_max_K: float        # steady rise at v_max
    v_loop_V: np.ndarray     # the major loop: inputs
    phase_loop_um: np.ndarray  # and the phase part


def reference(device) -> Reference:
    v_up = np.linspace(device.v_min_V, device.v_max_V, 121)
    seq = np.concatenate([v_up, v_up[::-1][1:]])
    h = device.hysteresis()
    ph = np.array([h.move(float(v)) for v in seq])
    u = device.bias_um + device.thermal_um_per_V * seq + ph
    dv = v_up[1] - v_up[0]
    slope = np.abs(np.diff(ph)) / dv
    return Reference(
        swing_um=float(np.ptp(u)), u_min_um=float(np.min(u)), u_max_um=float(np.max(u)),
        phase_half_um=float(device.phase_swing_um), slope_max_um_per_V=float(np.max(slope)),
        rise_max_K=float(device.rise_K(device.v_max_V)), v_loop_V=seq, phase_loop_um=ph,
    )


@lru_cache(maxsize=8)
def _cell_map(levels: int, v_min: float, v_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Band indices ``(p, q)`` (switch-up band, switch-down band) of every cell of ``density_um``.

    Found through the public interface only: a device whose cell weights are 1, 2, 3, ... is taken
    up to every grid line and peeked down to every lower line (first-order reversal curves); the
    mixed second difference of the switched-on weight is the weight, hence the index, of one cell.
    """
    n = levels * (levels + 1) // 2
    w = np.arange(1, n + 1, dtype=float)
    dev = base.BaseDevice(
        levels=levels, v_min_V=v_min, v_max_V=v_max, density_um=w, bias_um=0.0, thermal_um_per_V=0.0,
        kelvin_per_V2=1.0, ambient_C=25.0, transition_heating_C=68.0, transition_cooling_C=60.0,
        transition_width_C=5.0,
    )
    total = float(np.sum(w))
    lines = v_min + (v_max - v_min) * np.arange(levels + 1) / levels
    on = np.zeros((levels + 1, levels + 1))
    for i in range(levels + 1):
        h = dev.hysteresis()
        h.move(float(lines[i]))
        for j in range(levels + 1):
            on[i, j] = (h.peek(float(lines[min(j, i)])) + total) / 2.0
    p_of = np.full(n, -1)
    q_of = np.full(n, -1)
    for p in range(levels):
        for q in range(p + 1):
            wk = on[p + 1, q + 1] - on[p, q + 1] - on[p + 1, q] + on[p, q]
            k = int(round(wk)) - 1
            if 0 <= k < n and abs(wk - (k + 1)) < 1e-6 and p_of[k] < 0:
                p_of[k], q_of[k] = p, q
    if np.any(p_of < 0):
        raise RuntimeError("could not map the Preisach cells")
    return p_of, q_of


def cell_thresholds(device) -> tuple[np.ndarray, np.ndarray]:
    """Up and down thresholds (V, cell centres) of every cell of ``device.density_um``."""
    p, q = _cell_map(int(device.levels), float(device.v_min_V), float(device.v_max_V))
    delta = (device.v_max_V - device.v_min_V) / device.levels
    return device.v_min_V + (p + 0.5) * delta, device.v_min_V + (q + 0.5) * delta
