"""rig watch benchmark: what watching costs an acquisition, how soon the page shows a flushed sample, whether
the model so far keeps up, and how the page fares on a 20,000-sample session.

Run:  python benchmarks/watch_bench.py [--repeats 5] [--client auto|browser|http] [--skip overhead,refit,large]

Prints medians of repeated runs (times are wall-clock on this machine; the load average is printed):

1. **Overhead.**  The sequencer of ``rig acquire`` (in process, the same code) runs an L = 10 damped
   oscillation (57 points) on the simulated device on the *real* clock with a 0.1 s dwell -- ten samples a
   second, so that every poll of the watcher finds new data and redraws: the worst case for a watcher,
   two hundred times the sample rate of the paper's 20 s dwell.  The heater, sensor, clock and writer
   are wrapped in timing proxies (``acquire_bench.timed_run``): the sequencer's overhead per sample is
   the time between two samples minus the time spent inside them.  Runs alternate: alone, and with one
   ``rig watch`` (a separate process, as an operator runs it) plus one page client following it at the
   page's rate (the page's long poll of the state, and each changed figure fetched once): headless
   Chromium showing the real page (``--client browser``, the default when it is installed) or a plain
   HTTP client doing the same requests (``--client http``).
2. **Page latency.**  In those watched runs (ten samples a second) and in runs at one sample per second
   (L = 6, 23 points, 1 s dwell), each sample's flush time (the writer's ``append`` returned) against the
   first moment the page showed it -- in its numbers (the point count), and in the time figure (the
   state says how many points each figure shows) -- with the figures fetched (Chromium: the page's own
   record, ``window.rigWatch.updates``; both clocks are this machine's).
3. **Refit.**  An L = 30 damped oscillation with the thermal point (467 points, the simulated device's
   run as ``rig acquire`` records it) refitted on every 5th prefix, as the page does, on the watch's
   worker process (a job sent, the result received): cold (a fresh worker) and warm; the budget at one
   sample per second is 5 s per refit (every 5 points), 1 s to refit after every point.
4. **20,000 samples.**  A live session of 20,000 random-input points (L = 30), one more appended every
   0.5 s so that every poll redraws all figures: ``rig watch`` started cold (to ready, to its first
   state, to all figures drawn), the refit at 20,000 points, and the state answered while the figures are
   redrawn (a request every 50 ms for 10 s: median, p95, max), each figure's size.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from drivers import open_rig
from drivers.config import loads_config
from rig.acquisition import DwellSettings, FixedDwell, acquire, make_record, sequence_record
from rig.testing import NoBrowser, Process, close_browser, get, start_browser, wait_state
from sessions import ExcitationRecord, SessionWriter, read_session
from sessions.schema import SAMPLE_DTYPE

from acquire_bench import timed_run  # beside this file

REAL_CLOCK_SIM = """
driver = "sim"
clock = "real"
[heater]
max_V = 6.0
[sensor]
um_per_V = 5.0
[sim]
time_constant_s = 0.002
psd_noise_V = 0.0005
"""
#: The overhead runs: ten samples a second (an L = 10 damped oscillation, 57 points).
LEVELS, DWELL_S = 10, 0.1
#: The latency runs at one sample per second (an L = 6 damped oscillation, 23 points).
SLOW_LEVELS, SLOW_DWELL_S = 6, 1.0


def ms(x: float) -> str:
    return f"{1e3 * x:.3f} ms"


# ------------------------------------------------------------------ the page client
def http_client(url: str, stop, out) -> None:
    """Follow the page's requests (long poll of the state; each changed figure once) until ``stop``;
    put ``[(t_shown, n_applied, points in the time figure), ...]`` on ``out``."""
    version, figures, shown = 0, {}, []
    while not stop.is_set():
        status, _, body = get(f"{url}api/state?after={version}&wait=2", timeout=30)
        if status != 200:
            time.sleep(0.5)
            continue
        state = json.loads(body)
        if state["version"] == version:
            continue
        version = state["version"]
        for name, v in state.get("figures", {}).items():
            if figures.get(name) != v:
                get(f"{url}figure/{name}.svg?v={v}", timeout=30)
                figures[name] = v
        n = (state.get("progress") or {}).get("n_applied", 0)
        shown.append((time.time(), n, (state.get("drawn") or {}).get("time") or 0))
    out.put(shown)


class PageClient:
    """One page following ``url``: Chromium showing the real page, or :func:`http_client` in a process."""

    def __init__(self, url: str, kind: str) -> None:
        self.kind, self.url = kind, url
        if kind == "browser":
            self.drv = start_browser()
            self.drv.get(url)
        else:
            ctx = multiprocessing.get_context("spawn")
            self.stop_event, self.queue = ctx.Event(), ctx.Queue()
            self.proc = ctx.Process(target=http_client, args=(url, self.stop_event, self.queue), daemon=True)
            self.proc.start()

    def close(self) -> list[tuple[float, int, int]]:
        """Stop; every state the page showed: (wall time, applied points, points in the time figure)."""
        if self.kind == "browser":
            updates = self.drv.execute_script("return window.rigWatch.updates")
            close_browser(self.drv)
            return [(u["shown_ms"] / 1e3, u["n"], (u.get("drawn") or {}).get("time") or 0) for u in updates]
        self.stop_event.set()
        shown = self.queue.get(timeout=60)
        self.proc.join(10)
        return shown


def latencies(flushed: list[float], shown: list[tuple[float, int, int]], column: int) -> np.ndarray:
    """For each sample, the time from its flush to the first state shown that holds it (s): in the
    numbers (``column`` 1) or in the time figure (``column`` 2)."""
    out = []
    for k, t_flush in enumerate(flushed):
        later = [row[0] for row in shown if row[column] >= k + 1 and row[0] >= t_flush - 1e-3]
        if later:
            out.append(min(later) - t_flush)
    return np.array(out)


# ------------------------------------------------------------------ 1 and 2: overhead and latency
def one_run(tmp: Path, name: str, client: str | None, levels: int = LEVELS,
            dwell_s: float = DWELL_S) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """One real-clock run, alone (``client`` None) or watched: the sequencer's overhead per sample, and the
    page's latencies (numbers, time figure) per sample."""
    path = tmp / f"{name}.h5"
    settings = DwellSettings(FixedDwell(dwell_s), readings=1)
    cfg = loads_config(REAL_CLOCK_SIM, "benchmark rig.toml")
    watch = page = None
    if client is not None:
        watch = Process("watch", path, "--json")
        page = PageClient(watch.ready["url"], client)
        time.sleep(2.0)  # the watch and its fork server started, the page waiting for the file
    try:
        with open_rig(cfg) as rig:
            record = make_record(sequence_record("damped", rig.heater.window, levels=levels), settings)
            flushed: list[float] = []
            over, _ = timed_run(rig, record, settings, path, flushed)
        if watch is None:
            return over, None
        wait_state(watch.ready["url"], lambda s: (s.get("progress") or {}).get("n_applied") == len(flushed)
                   and (s.get("model") or {}).get("behind") == 0, timeout=30, what="with the whole run")
        time.sleep(1.0)
        shown = page.close()
        page = None
        return over, (latencies(flushed, shown, 1), latencies(flushed, shown, 2))
    finally:
        if page is not None:
            page.close()
        if watch is not None:
            watch.stop()


def overhead_and_latency(repeats: int, client: str, tmp: Path) -> dict:
    alone, watched, numbers, figure = [], [], [], []
    for r in range(repeats):
        o, _ = one_run(tmp, f"alone-{r}", None)
        alone.append(o)
        o, (ln, lf) = one_run(tmp, f"watched-{r}", client)
        watched.append(o)
        numbers.append(ln)
        figure.append(lf)
        print(f"  repeat {r + 1}: median overhead alone {ms(np.median(alone[-1]))}, watched {ms(np.median(o))}; "
              f"page latency median {np.median(ln):.2f} s (numbers), {np.median(lf):.2f} s (figure)", flush=True)
    a = statistics.median(float(np.median(x)) for x in alone)
    w = statistics.median(float(np.median(x)) for x in watched)
    out = {"alone_median_s": a, "watched_median_s": w, "added": w / a - 1.0,
           "alone_p99_s": statistics.median(float(np.percentile(x, 99)) for x in alone),
           "watched_p99_s": statistics.median(float(np.percentile(x, 99)) for x in watched)}
    out.update(summarise_latency(numbers, figure))
    return out


def summarise_latency(numbers: list[np.ndarray], figure: list[np.ndarray]) -> dict:
    out = {}
    for name, lat in (("numbers", np.concatenate(numbers)), ("figure", np.concatenate(figure))):
        out[name] = {"median_s": float(np.median(lat)), "p95_s": float(np.percentile(lat, 95)),
                     "max_s": float(np.max(lat)), "samples": int(lat.size)}
    return out


def latency_at_one_per_second(repeats: int, client: str, tmp: Path) -> dict:
    numbers, figure = [], []
    for r in range(repeats):
        _, (ln, lf) = one_run(tmp, f"slow-{r}", client, SLOW_LEVELS, SLOW_DWELL_S)
        numbers.append(ln)
        figure.append(lf)
    return summarise_latency(numbers, figure)


def print_latency(o: dict) -> None:
    for what, label in (("numbers", "its numbers (count, status)"), ("figure", "the time figure")):
        lat = o[what]
        print(f"  page latency after a flush, {label} ({lat['samples']} samples): median "
              f"{lat['median_s']:.2f} s, p95 {lat['p95_s']:.2f} s, max {lat['max_s']:.2f} s")


# ------------------------------------------------------------------ 3: refit
def refit_keeps_up(tmp: Path, method: str) -> dict:
    from rig.watch.refit import RefitJob, refit
    from rig.watch.worker import Worker

    path = tmp / f"refit-{method}.h5"
    with open_rig() as rig:  # the simulated device on its virtual clock: the L = 30 run of rig acquire
        settings = DwellSettings(FixedDwell(20.0), readings=4)
        acquire(rig, make_record(sequence_record("damped", rig.heater.window), settings), path)
    s = read_session(path)
    g = s.grid
    worker = Worker(refit)
    times, jobs = [], []
    try:
        for n in range(5, s.n_samples + 1, 5):
            job = RefitJob(s.inputs[:n], s.outputs[:n], g.levels, g.v_min, g.v_max, method=method)
            t0 = time.perf_counter()
            assert worker.submit(job)
            while (result := worker.result()) is None:
                time.sleep(0.001)
            times.append(time.perf_counter() - t0)
            jobs.append(result.wall_s)
            assert result.error is None, result.error
    finally:
        worker.close()
    warm = np.array(times[1:])
    return {"method": method, "cold_s": times[0], "warm_median_s": float(np.median(warm)),
            "warm_p95_s": float(np.percentile(warm, 95)), "warm_max_s": float(np.max(warm)),
            "job_max_s": float(np.max(jobs[1:])), "fits": len(times), "points": s.n_samples}


# ------------------------------------------------------------------ 4: a 20,000-sample session
def large_session(tmp: Path, n: int = 20_000) -> dict:
    from drivers.clock import VirtualClock
    from drivers.sim import SimParams, SimVO2
    from identify import Excitation, Grid

    path = tmp / "large.h5"
    truth = SimVO2(SimParams(), VirtualClock()).true_model()
    exc = Excitation.random(Grid(30, 0.0, 6.0), n + 200, seed=4)
    y = truth.predict(exc.inputs) + np.random.default_rng(4).normal(0, 0.01, exc.inputs.size)
    writer = SessionWriter.create(path, ExcitationRecord.from_excitation(exc), fsync_interval_s=None)
    rows = np.zeros(n, SAMPLE_DTYPE)
    rows["t_s"], rows["input"], rows["output"] = 2.0 * np.arange(1, n + 1), exc.inputs[:n], y[:n]
    rows["measured"] = rows["settled"] = True
    writer.extend(rows)
    t0 = time.perf_counter()
    watch = Process("watch", path, "--json")
    base = watch.ready["url"]
    ready = time.perf_counter() - t0
    try:
        wait_state(base, lambda s: "progress" in s, timeout=60, what="a first state")
        first = time.perf_counter() - t0
        st = wait_state(base, lambda s: {"time", "loop", "model"} <= set(s["figures"]), timeout=120,
                        what="all figures")
        drawn = time.perf_counter() - t0
        refit_s = st["model"]["wall_s"]
        sizes = {name: len(get(f"{base}figure/{name}.svg")[2]) for name in ("time", "loop", "model")}
        # live: one more point every 0.5 s, so every poll redraws the figures of 20,000 points
        lat, k, end, next_append = [], n, time.monotonic() + 10.0, 0.0
        while time.monotonic() < end:
            if time.monotonic() >= next_append:
                writer.append(2.0 * (k + 1), exc.inputs[k], y[k], measured=True, settled=True)
                k, next_append = k + 1, time.monotonic() + 0.5
            t = time.perf_counter()
            assert get(f"{base}api/state")[0] == 200
            lat.append(time.perf_counter() - t)
            time.sleep(0.05)
        final = wait_state(base, lambda s: s["progress"]["n_applied"] == k, timeout=30, what="the last point")
        lat = np.array(lat)
        return {"n": n, "ready_s": ready, "first_state_s": first, "all_figures_s": drawn, "refit_s": refit_s,
                "state_median_s": float(np.median(lat)), "state_p95_s": float(np.percentile(lat, 95)),
                "state_max_s": float(np.max(lat)), "requests": int(lat.size), "sizes": sizes,
                "appended": k - n, "figure_versions": final["figures"]}
    finally:
        watch.stop()
        writer.finish()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--client", choices=("auto", "browser", "http"), default="auto")
    ap.add_argument("--skip", default="", help="comma-separated parts to skip: overhead, refit, large")
    args = ap.parse_args()
    skip = set(filter(None, args.skip.split(",")))
    client = args.client
    if client in ("auto", "browser"):
        try:
            close_browser(start_browser())
            client = "browser"
        except NoBrowser as exc:
            if args.client == "browser":
                raise SystemExit(f"--client browser: {exc}")
            client = "http"
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2-core machine, shared)", flush=True)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if "overhead" not in skip:
            print(f"1-2. overhead and page latency: L = {LEVELS} damped oscillation, {DWELL_S} s dwell, real "
                  f"clock, {args.repeats} repeats, page client: {client}", flush=True)
            o = overhead_and_latency(args.repeats, client, tmp)
            print(f"  sequencer overhead per sample, median of per-run medians: alone {ms(o['alone_median_s'])}, "
                  f"with one watcher and its page {ms(o['watched_median_s'])}: {100 * o['added']:+.1f} %; "
                  f"p99 {ms(o['alone_p99_s'])} / {ms(o['watched_p99_s'])}")
            print_latency(o)
            slow = max(1, min(2, args.repeats))
            print(f"  the same at one sample per second (L = {SLOW_LEVELS}, {SLOW_DWELL_S} s dwell, {slow} runs):",
                  flush=True)
            print_latency(latency_at_one_per_second(slow, client, tmp))
        if "refit" not in skip:
            print("3. refit on the worker, L = 30 damped oscillation with the thermal point, every 5th prefix:",
                  flush=True)
            for method in ("smooth_nn", "ls"):
                r = refit_keeps_up(tmp, method)
                print(f"  {method}: {r['fits']} fits up to {r['points']} points; cold (fresh worker) "
                      f"{r['cold_s']:.2f} s; warm median {r['warm_median_s']:.3f} s, p95 {r['warm_p95_s']:.3f} s, "
                      f"max {r['warm_max_s']:.3f} s (budget at 1 sample/s: 5 s per refit of 5 points, 1 s per point)",
                      flush=True)
        if "large" not in skip:
            r = large_session(tmp)
            print(f"4. a live session of {r['n']} samples: rig watch ready in {r['ready_s']:.2f} s (cold), first "
                  f"state {r['first_state_s']:.2f} s, all figures {r['all_figures_s']:.2f} s; refit at {r['n']} "
                  f"points {r['refit_s']:.2f} s; state answered in median {ms(r['state_median_s'])}, p95 "
                  f"{ms(r['state_p95_s'])}, max {ms(r['state_max_s'])} over {r['requests']} requests while "
                  f"{r['appended']} appended points were redrawn; figure sizes "
                  + ", ".join(f"{k} {v / 1024:.0f} KiB" for k, v in r["sizes"].items()))
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (pid {os.getpid()})")


if __name__ == "__main__":
    main()
