"""Acquisition benchmark: a full L = 30 run on the simulated device, and the sequencer's own cost per sample.

Run:  python benchmarks/acquire_bench.py [--repeats 5]

Prints medians of repeated runs:

* a whole L = 30 damped-oscillation run with the thermal point (467
  points; fixed 20 s dwell, K = 4 readings per point) on the in-process
  simulated device and its virtual clock, through
  :func:`rig.acquisition.acquire` -- session created, negative saturation,
  every point applied, measured, appended and flushed, session finished --
  in wall time; the same with ``--measure 100``; and the ``rig acquire``
  command end to end (a new process: interpreter start and imports
  included, reported separately);
* the sequencer's own overhead per sample: the heater, the sensor and the
  clock are wrapped in timing proxies (they satisfy the same protocols),
  and the time between two recorded samples minus the time spent inside
  them is what the sequencer itself costs -- planning, logging, the HDF5
  append and flush, the progress callback.  The HDF5 append + flush is
  also timed alone;
* over Modbus TCP on loopback (``rig serve-sim`` in its own process, the
  real clock, no dwell, K = 1): the time per applied point, and of it the
  set-point read-back that the sequencer does after every write (issue 28:
  a set-point acknowledged but not applied must not go unnoticed) -- the
  cost a real bench pays per point for it.  Before the read-back existed
  the second figure is 0.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from drivers import open_rig
from rig.acquisition import (
    AcquisitionPlan,
    DwellSettings,
    FixedDwell,
    Hooks,
    Sequencer,
    acquire,
    make_record,
    sequence_record,
)
from rig.acquisition.progress import ProgressBar
from sessions import SessionWriter

SETTINGS = DwellSettings(FixedDwell(20.0), readings=4)


class Stopwatch:
    """Accumulated seconds spent inside the wrapped objects."""

    def __init__(self) -> None:
        self.inside = 0.0


class Timed:
    """A proxy that times every method call of ``target`` into ``watch`` (same interface, so same protocol)."""

    def __init__(self, target, watch: Stopwatch) -> None:
        self._target, self._watch = target, watch

    def __getattr__(self, name):
        attr = getattr(self._target, name)
        if not callable(attr):
            return attr
        watch = self._watch

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return attr(*args, **kwargs)
            finally:
                watch.inside += time.perf_counter() - t0

        return timed


def full_runs(repeats: int, tmp: Path, measure: int | None) -> list[float]:
    times = []
    for r in range(repeats):
        path = tmp / f"full-{measure}-{r}.h5"
        with open_rig() as rig:
            rec = make_record(sequence_record("damped", rig.heater.window), SETTINGS, measure, 0)
            t0 = time.perf_counter()
            out = acquire(rig, rec, path)
            times.append(time.perf_counter() - t0)
            assert out.status.value == "complete"
    return times


def cli_runs(repeats: int, tmp: Path) -> tuple[list[float], list[float]]:
    exe = str(Path(sys.executable).with_name("rig"))
    runs, starts = [], []
    for r in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([exe, "acquire", "--out", str(tmp / f"cli-{r}.h5"), "--json"], check=True,
                       capture_output=True)
        runs.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import rig.cli"], check=True)
        starts.append(time.perf_counter() - t0)
    return runs, starts


def timed_run(rig, record, settings: DwellSettings, path: Path,
              flushed: list[float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Run ``record`` on ``rig`` into ``path`` with the heater, sensor, clock and writer timed: the
    sequencer's overhead per sample (s) and its HDF5 append + flush part (s), one entry per sample.
    ``flushed`` receives the wall-clock time (``time.time()``) each sample was on disk."""
    plan = AcquisitionPlan.from_record(record)
    device = Stopwatch()
    writer = SessionWriter.create(path, record)
    recorder = Stopwatch()
    bar = ProgressBar(plan.n_points, enabled=False)
    stamps: list[tuple[float, float, float]] = []

    def on_sample(result):
        if flushed is not None:
            flushed.append(time.time())
        bar.update(result)
        stamps.append((time.perf_counter(), device.inside, recorder.inside))

    seq = Sequencer(Timed(rig.heater, device), Timed(rig.sensor, device), Timed(rig.clock, device),
                    plan, settings, Timed(writer, recorder), **vars(Hooks(on_sample=on_sample)))
    seq.saturate()
    stamps.append((time.perf_counter(), device.inside, recorder.inside))
    seq.run()
    writer.finish()
    t = np.array(stamps)
    return np.diff(t[:, 0]) - np.diff(t[:, 1]), np.diff(t[:, 2])


def overhead(repeats: int, tmp: Path) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample sequencer overhead (s) and its HDF5 append + flush part (s), every sample of every repeat."""
    over, appends = [], []
    for r in range(repeats):
        with open_rig() as rig:
            rec = make_record(sequence_record("damped", rig.heater.window), SETTINGS)
            o, a = timed_run(rig, rec, SETTINGS, tmp / f"over-{r}.h5")
        over.append(o)
        appends.append(a)
    return np.concatenate(over), np.concatenate(appends)


SERVED = """driver = "modbus"
[heater]
max_V = 6.0
[sensor]
um_per_V = 5.0
[modbus]
host = "127.0.0.1"
port = {port}
[modbus.setpoint]
address = 0
[modbus.psd]
address = 0
"""


class ReadBacks(Timed):
    """The heater, with only its ``read_voltage`` calls timed (the set-point read-back)."""

    def __getattr__(self, name):
        return super().__getattr__(name) if name == "read_voltage" else getattr(self._target, name)


def modbus_points(repeats: int, tmp: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wall time per applied point (s) and the read-back's part of it (s), every point of every repeat, over
    Modbus TCP to ``rig serve-sim`` in another process (L = 20 damped, no dwell, K = 1); and the wall time per
    point of the same runs with the read-back switched off, alternated with them (same server, same load)."""
    from drivers.config import loads_config

    exe = str(Path(sys.executable).with_name("rig"))
    server = subprocess.Popen([exe, "serve-sim", "--modbus", "127.0.0.1:0", "--json"], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True)
    try:
        import json

        port = int(json.loads(server.stdout.readline())["modbus"].rsplit(":", 1)[1])
        cfg = loads_config(SERVED.format(port=port), "bench")
        settings = DwellSettings(FixedDwell(0.0), readings=1)
        per_point, readback, without = [], [], []
        for r in range(2 * repeats):
            off = r % 2 == 1
            with open_rig(cfg) as rig:
                rec = make_record(sequence_record("damped", rig.heater.window, levels=20), settings)
                plan = AcquisitionPlan.from_record(rec)
                writer = SessionWriter.create(tmp / f"modbus-{r}.h5", rec)
                watch = Stopwatch()
                stamps: list[tuple[float, float]] = []
                seq = Sequencer(ReadBacks(rig.heater, watch), rig.sensor, rig.clock, plan, settings, writer,
                                on_sample=lambda result: stamps.append((time.perf_counter(), watch.inside)))
                if off:
                    seq._read_back = lambda *args: None  # as before issue 28 (no-op where it does not exist)
                seq.saturate()
                stamps.append((time.perf_counter(), watch.inside))
                seq.run()
                writer.finish()
            t = np.array(stamps)
            if off:
                without.append(np.diff(t[:, 0]))
            else:
                per_point.append(np.diff(t[:, 0]))
                readback.append(np.diff(t[:, 1]))
        return np.concatenate(per_point), np.concatenate(readback), np.concatenate(without)
    finally:
        server.terminate()
        server.wait(10)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        full = statistics.median(full_runs(args.repeats, tmp, None))
        cs = statistics.median(full_runs(args.repeats, tmp, 100))
        print(f"full L=30 run (467 points, K=4, fixed 20 s dwell, virtual clock), in process: "
              f"{full:.3f} s wall (median of {args.repeats}); with --measure 100: {cs:.3f} s")
        cli, start = cli_runs(max(1, args.repeats // 2 + 1), tmp)
        print(f"rig acquire --out S.h5 (same run, new process): {statistics.median(cli):.2f} s wall, "
              f"of which interpreter start + imports (python -c 'import rig.cli'): {statistics.median(start):.2f} s")
        over, appends = overhead(args.repeats, tmp)
        print(f"sequencer overhead per sample (all but heater, sensor, clock): median {np.median(over) * 1e3:.3f} ms, "
              f"p99 {np.percentile(over, 99) * 1e3:.2f} ms over {over.size} samples; "
              f"of which HDF5 append + flush: median {np.median(appends) * 1e3:.3f} ms, "
              f"p99 {np.percentile(appends, 99) * 1e3:.2f} ms")
        per_point, readback, without = modbus_points(args.repeats, tmp)
        print(f"over Modbus TCP on loopback (rig serve-sim, L=20, no dwell, K=1): per point median "
              f"{np.median(per_point) * 1e3:.3f} ms, p99 {np.percentile(per_point, 99) * 1e3:.2f} ms; of which the "
              f"set-point read-back: median {np.median(readback) * 1e3:.3f} ms, "
              f"p99 {np.percentile(readback, 99) * 1e3:.2f} ms, over {per_point.size} points; alternated runs "
              f"without the read-back: per point median {np.median(without) * 1e3:.3f} ms, "
              f"p99 {np.percentile(without, 99) * 1e3:.2f} ms")
    print(f"(pid {os.getpid()}, load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
