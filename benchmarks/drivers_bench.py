"""Drivers benchmark: the simulated device's cost per sample, and protocol round trips on loopback.

Run:  python benchmarks/drivers_bench.py [--repeats 5]

Prints medians of repeated runs:

* the whole L = 30 damped oscillation with the thermal point (467 points)
  through an in-process sim ``Rig`` on the virtual clock -- set, a settled
  dwell (40 tau), K = 4 readings per point -- against evaluating the true
  model on the same inputs (``PreisachModel.predict``), the reference;
* one set-point write plus one PSD read over each transport to the
  simulated bench on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import statistics
import time

from drivers import open_rig
from identify import damped_oscillation
from rig.testing import EXACT, config, modbus_toml, serial_toml, served

K = 4


def sim_run(repeats: int) -> None:
    runs, refs = [], []
    for _ in range(repeats):
        with open_rig() as rig:
            truth = rig.device.true_model()
            v = damped_oscillation(truth.grid, thermal_term=True)
            dwell = 40 * rig.config.sim.time_constant_s
            t0 = time.perf_counter()
            for x in v:
                rig.heater.set_voltage(x)
                rig.clock.sleep(dwell)
                for _ in range(K):
                    rig.sensor.read()
            runs.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        truth.predict(v)
        refs.append(time.perf_counter() - t0)
    run, ref = statistics.median(runs), statistics.median(refs)
    print(f"sim rig, L=30 damped oscillation ({v.size} points, K={K}, virtual clock): "
          f"{run * 1e3:.1f} ms total, {run / v.size * 1e6:.0f} us per point "
          f"(model.predict alone: {ref * 1e3:.1f} ms; ratio {run / ref:.1f}x)")


def transports(repeats: int) -> None:
    with served(modbus=True, modbus_rtu=True, serial="socket://127.0.0.1:0", **EXACT) as bench:
        cases = {
            "modbus tcp": (modbus_toml(bench, "tcp"), 200),
            "modbus rtu-over-tcp": (modbus_toml(bench, "rtu-over-tcp"), 200),
            "modbus rtu (socket://, 115200 Bd)": (modbus_toml(bench, "rtu"), 20),
            "serial socket:// (set + verify + read)": (serial_toml(bench.endpoints["serial"]), 200),
        }
        for name, (text, n) in cases.items():
            with open_rig(config(text)) as rig:
                times = []
                for r in range(repeats):
                    t0 = time.perf_counter()
                    for i in range(n):
                        rig.heater.set_voltage(0.001 * (i % 100))
                        rig.sensor.read()
                    times.append((time.perf_counter() - t0) / n)
            print(f"{name}: {statistics.median(times) * 1e3:.2f} ms per set + read (median of {repeats} x {n})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    sim_run(args.repeats)
    transports(args.repeats)


if __name__ == "__main__":
    main()
