"""Measure each mechanism's effect size at strength 1 with this package's own code (for README.md).

    python -m benchmarks.blind.gen_e.effect_sizes [forms_per_device] [devices]

For every mechanism: draws forms, simulates a noise-free session (the example schedules of
``schedules.py``) at strength 1 and reports the deviation from the clean device in % of the clean
output swing: the median over forms of the rms deviation, and the median and maximum of the peak deviation.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from .. import base
from . import LIBRARY, OUTSIDE, draw_form, simulate, schedules
from ._session import device_scale


def measure(n_forms: int = 8, n_devices: int = 3, families=None) -> list[tuple]:
    rows = []
    for fam in families or (LIBRARY + OUTSIDE):
        rms, peak, times = [], [], []
        for dseed in range(n_devices):
            dev = base.draw_device(100 + dseed)
            sch = schedules.session(dseed)
            clean = simulate(dev, sch, [], 0, None)
            swing = device_scale(dev)["swing"]
            for f in range(n_forms):
                form = draw_form(fam, np.random.default_rng([dseed, f, 7]))
                t = time.perf_counter()
                out = simulate(dev, sch, [(fam, form, 1.0)], 11 + f, None)
                times.append(time.perf_counter() - t)
                d = np.concatenate([a["y_um"] - b["y_um"] for a, b in zip(out, clean)]) / swing * 100
                rms.append(np.sqrt(np.mean(d * d)))
                peak.append(np.max(np.abs(d)))
        rows.append((fam, float(np.median(rms)), float(np.median(peak)), float(np.max(peak)), float(np.median(times))))
    return rows


if __name__ == "__main__":
    nf = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    nd = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    print("| mechanism | median rms (% swing) | median peak (% swing) | max peak (% swing) | median time (s) |")
    print("|---|---|---|---|---|")
    for fam, r, p, pm, t in measure(nf, nd):
        print(f"| `{fam}` | {r:.2f} | {p:.2f} | {pm:.2f} | {t:.2f} |")
