"""Speed of the inversion (issue 19): microseconds per target, warm and cold, against the forward model.

Run:  python benchmarks/inverse_speed.py [--repeats 5] [--points 2000]

Warm: :func:`identify.inverse.invert` on a whole target sequence in one
call, in this process, median over ``--repeats`` runs, per target; the
reference measured in the same run is the forward model stepped one input
at a time on the same voltages (:class:`identify.forward.HysteresisState`,
``apply``).  Models: the simulated device's own (equation (22), the
transition's density on its grid) at L = 30 and L = 200; at L = 30 also
with each invertible effect (``joule_power``, ``creep``, ``thermal_lag``,
``sensor_nonlinearity``; fitted-looking parameters).  Target families:
``steps`` (random steps with reversals over the range), ``sines`` (a
decaying sinusoid: nested minor loops), ``ramps`` (slow triangles),
``random`` (independent uniform targets: every step a long jump, the worst
case).  Cold: ``rig invert MODEL.json TARGET.csv --out V.csv`` in a fresh
process (start-up, reading, the major loop's range check, writing), median
wall time of three.

Targets (issue 19): <= 50 us per step at L = 30, <= 1 ms at L = 200.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from drivers.clock import VirtualClock
from drivers.config import default_config
from drivers.sim import SimVO2
from identify.effects import EFFECTS, pipeline_order
from identify.inverse import invert
from identify.model_json import model_to_dict
from sessions.targets import Targets, write_targets


def families(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    steps = np.cumsum(rng.choice([-1.0, 1.0], n) * rng.uniform(0.5, 6.0, n))
    steps = -2.5 + 9.5 * np.sin(steps / 7.0)  # a walk folded into [-12, 7] um: steps of every size, reversals
    period = 40
    sines = -2.5 + 9.5 * np.cos(2 * np.pi * k / 10) * np.exp(-(k % period) / period * 2.5)
    tri = np.abs((k % 100) / 50.0 - 1.0)
    ramps = -12.0 + 19.0 * tri
    return {"steps": steps, "sines": sines, "ramps": ramps, "random": rng.uniform(-12.0, 7.0, n)}


def device_model(levels: int):
    return SimVO2(default_config(levels=levels).sim, VirtualClock()).true_model()


EFFECT_CASES = {
    "joule_power": [EFFECTS["joule_power"]({"um_per_V2": 0.05, "um_per_V4": -0.001})],
    "creep": [EFFECTS["creep"]({"drive": "reversal", "time_constants_s": [2.0, 6.3, 20.0, 63.0, 200.0, 632.0, 2000.0],
                                "weights": [0.0, 0.01, 0.02, 0.02, 0.01, 0.0, 0.0]})],
    "thermal_lag": [EFFECTS["thermal_lag"]({"drive": "power", "time_constants_s": [1.0, 4.2], "fractions": [0.02, 0.01]})],
    "sensor_nonlinearity": [EFFECTS["sensor_nonlinearity"]({"knots_z": [-1, -0.5, 0, 0.5, 1],
                                                            "coefficients_um": [0.05, -0.08, 0.04],
                                                            "centre_um": -4.0, "half_range_um": 14.0})],
}


def warm(model, y: np.ndarray, repeats: int) -> tuple[float, float, int]:
    """Median us per target of the inversion, and of the forward model stepped on the same voltages."""
    t = 2.0 * np.arange(1, y.size + 1)
    d = np.full(y.size, 2.0)
    inv, fwd, unreachable = [], [], 0
    for _ in range(repeats):
        r = invert(model, y, t, d, domain=(0.0, 6.0))
        inv.append(r.seconds / y.size)
        unreachable = r.n_unreachable
        state = model.without_effects().state()
        t0 = time.perf_counter()
        for v in r.voltages.tolist():
            state.apply(v)
        fwd.append((time.perf_counter() - t0) / y.size)
    return 1e6 * float(np.median(inv)), 1e6 * float(np.median(fwd)), unreachable


def cold(model, y: np.ndarray, directory: Path, repeats: int = 3) -> tuple[float, float]:
    """Median wall time (s) of ``rig invert`` in a fresh process, and its own us per target."""
    exe = shutil.which("rig", path=os.path.dirname(sys.executable)) or shutil.which("rig")
    mpath, tpath, out = directory / "model.json", directory / "target.csv", directory / "v.csv"
    mpath.write_text(json.dumps(model_to_dict(model)))
    write_targets(tpath, Targets(2.0 * np.arange(1, y.size + 1), y))
    walls, per = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        p = subprocess.run([exe, "invert", mpath, tpath, "--out", out, "--force", "--json"], capture_output=True,
                           text=True, check=True)
        walls.append(time.perf_counter() - t0)
        per.append(json.loads(p.stdout)["us_per_step"])
    return float(np.median(walls)), float(np.median(per))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--points", type=int, default=2000)
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    fam = families(args.points)
    print(f"{args.points} targets per sequence, median of {args.repeats}; us per target (warm, in process)")
    print(f"{'model':28s} {'family':7s} {'invert_us':>10s} {'forward_us':>11s} {'ratio':>6s} {'unreach':>7s} "
          f"{'target':>8s}")
    for levels, limit in ((30, 50.0), (200, 1000.0)):
        model = device_model(levels)
        for name, y in fam.items():
            inv, fwd, un = warm(model, y, args.repeats)
            print(f"{'device, L = ' + str(levels):28s} {name:7s} {inv:10.1f} {fwd:11.1f} {inv / fwd:6.1f} {un:7d} "
                  f"{'met' if inv <= limit else 'NOT MET':>8s}")
    base = device_model(30)
    n_eff = min(args.points, 500)
    for name, effects in EFFECT_CASES.items():
        model = dataclasses.replace(base, effects=tuple(pipeline_order(effects)))
        for fname in ("steps", "sines"):
            inv, fwd, un = warm(model, fam[fname][:n_eff], max(1, args.repeats // 2))
            print(f"{'L = 30 with ' + name:28s} {fname:7s} {inv:10.1f} {fwd:11.1f} {inv / fwd:6.1f} {un:7d} "
                  f"{'(effect)':>8s}")
    with tempfile.TemporaryDirectory() as d:
        for levels in (30, 200):
            wall, per = cold(device_model(levels), fam["steps"], Path(d))
            print(f"cold: rig invert, L = {levels}, {args.points} steps targets: {wall:.2f} s wall (median of 3), "
                  f"{per:.1f} us per target inside it")
    print(f"load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end (2 cores)")


if __name__ == "__main__":
    main()
