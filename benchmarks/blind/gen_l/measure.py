"""Measure the deviation each mechanism makes at strength 1 (for README.md's table).

    python -m benchmarks.blind.gen_l.measure [n_forms]

For each mechanism: ``n_forms`` (device, form, seed) triples, a session like the
harness's (identification + check run, see ``schedules.py``), noise-free; the
deviation from the clean device in % of the clean session's output swing
(max - min): its rms over all readings and its largest value.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from .. import base
from . import schedules
from .core import simulate
from .forms import LIBRARY, OUTSIDE, draw_form


def measure(family: str, n_forms: int = 12, strength: float = 1.0):
    sess = schedules.session(0)
    rms, peak, secs = [], [], []
    for j in range(n_forms):
        device = base.draw_device(100 + j)
        clean = np.concatenate([base.clean_outputs(device, s["v_V"]) for s in sess])
        swing = clean.max() - clean.min()
        form = draw_form(family, np.random.default_rng(1000 + j))
        t0 = time.perf_counter()
        out = simulate(device, sess, [(family, form, strength)], j, None)
        secs.append(time.perf_counter() - t0)
        dev = np.concatenate([o["y_um"] for o in out]) - clean
        rms.append(100 * np.sqrt(np.mean(dev**2)) / swing)
        peak.append(100 * np.max(np.abs(dev)) / swing)
    return np.array(rms), np.array(peak), max(secs)


def main(n_forms: int = 12) -> None:
    print("| mechanism | rms dev. median [min-max] (% swing) | max dev. median [min-max] (% swing) | slowest session (s) |")
    print("|---|---|---|---|")
    for fam in LIBRARY + OUTSIDE:
        r, p, s = measure(fam, n_forms)
        print(f"| `{fam}` | {np.median(r):.2f} [{r.min():.2f}-{r.max():.2f}] "
              f"| {np.median(p):.2f} [{p.min():.2f}-{p.max():.2f}] | {s:.2f} |", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 12)
