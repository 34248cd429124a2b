"""The mechanism names this generator answers to (SPEC.md's library, the two outside ones, and ours)."""

from __future__ import annotations

LIBRARY: tuple[str, ...] = (
    "thermal_lag",
    "creep",
    "baseline_drift",
    "ambient_drift",
    "joule_power",
    "sensor_nonlinearity",
    "reversible",
    "interaction",
    "first_point",
    "gain_drift",
)

#: ``conductance_aging`` is this generator's own outside mechanism (README.md).
OUTSIDE: tuple[str, ...] = ("backlash", "accommodation", "conductance_aging")

ALL: tuple[str, ...] = LIBRARY + OUTSIDE
