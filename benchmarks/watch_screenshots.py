"""Screenshots of rig watch for docs/watch/ (and the README): a live run, the same run finished, the shared
FORC measurement, and a check run with the diagnosis's where bins.

Run:  python benchmarks/watch_screenshots.py [--out docs/watch]

Everything runs as an operator would: ``rig serve-sim`` (the simulated device on the real clock, on
loopback), ``rig acquire`` against it (L = 30 damped oscillation with the thermal point, 0.05 s dwell so
that the run takes half a minute), ``rig watch`` on the session, and headless Chromium (Debian's) showing
the page.  The FORC page is ``rig import`` of ``../shared/data/forc/MD00-2361.forc``; the check run is the
demo's pair of runs with creep switched on in the device (:mod:`rig.diagnosis.simulate`), watched with
``--fit``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from rig.testing import Child, client_config, close_browser, rig, serve_sim, start_browser, wait_state, watch

ROOT = Path(__file__).resolve().parents[1]

WIDTH = 1280


def shoot(drv, path: Path) -> None:
    """A screenshot of the whole page."""
    height = drv.execute_script("return document.documentElement.scrollHeight")
    drv.set_window_size(WIDTH, height + 140)
    time.sleep(0.5)
    drv.save_screenshot(str(path))
    print(f"wrote {path}")


def settled(state: dict) -> bool:
    """The run over, the model fitted on all of it, and every figure drawn from the newest data."""
    return (state.get("status") in ("complete", "aborted", "failed") and (state.get("model") or {}).get("behind") == 0
            and not state.get("stale") and state.get("figures"))


def live_run(tmp: Path, out: Path, drv) -> None:
    server = serve_sim(tmp)
    path = tmp / "live.h5"
    try:
        with watch(path) as w:
            base = w.ready["url"]
            child = Child("--config", client_config(server, tmp), "--levels", 30, "--dwell", 0.05, "--readings", 1,
                          "--operator", "bench", "--out", path)
            drv.get(base)
            state = wait_state(base, lambda s: (s.get("progress") or {}).get("n_applied", 0) >= 200, timeout=120)
            n = state["progress"]["n_applied"]
            wait_state(base, lambda s: (s.get("model") or {}).get("status") == "fitted"
                       and (s.get("drawn") or {}).get("time", 0) >= n, timeout=60)
            shoot(drv, out / "live-running.png")
            code, _, err = child.finish(timeout=300)
            assert code == 0, err
            wait_state(base, lambda s: settled(s) and (s.get("drawn") or {}).get("model") == 467, timeout=120)
            time.sleep(1.0)
            shoot(drv, out / "live-complete.png")
    finally:
        server.stop()


def forc_page(tmp: Path, out: Path, drv) -> None:
    source = ROOT.parent / "shared" / "data" / "forc" / "MD00-2361.forc"
    if not source.exists():
        print(f"skipped the FORC page: no {source}")
        return
    path = tmp / "md.h5"
    run = rig("import", source, "--format", "micromag", "--out", path)
    assert run.code == 0, run.err
    with watch(path) as w:
        base = w.ready["url"]
        drv.get(base)
        wait_state(base, lambda s: settled(s) and "model" in s["figures"], timeout=300)
        time.sleep(1.0)
        shoot(drv, out / "forc.png")


def check_page(tmp: Path, out: Path, drv) -> None:
    from rig.diagnosis.demo import demo_strength
    from rig.diagnosis.simulate import SimulatedBench, simulate

    (tmp / "demo").mkdir()
    fit, check = simulate(SimulatedBench("creep", demo_strength("creep")), tmp / "demo")
    with watch(check, "--fit", fit) as w:
        base = w.ready["url"]
        drv.get(base)
        wait_state(base, lambda s: settled(s) and "where" in s["figures"], timeout=300)
        time.sleep(1.0)
        shoot(drv, out / "check-where.png")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "watch")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    drv = start_browser()
    try:
        with tempfile.TemporaryDirectory() as d:
            tmp = Path(d)
            live_run(tmp, args.out, drv)
            check_page(tmp, args.out, drv)
            forc_page(tmp, args.out, drv)
    finally:
        close_browser(drv)


if __name__ == "__main__":
    main()
