"""``rig watch`` in a real browser: headless Chromium (Debian's, through selenium and chromedriver) on the
page of a run that ``rig acquire`` writes against ``rig serve-sim`` -- three processes and a browser, all on
loopback -- and on an imported FORC session served beyond loopback.  Checked as a person would: the title
and status, the point count growing, the figures' axis labels in the session's units, the access token.

Without Chromium and its driver these tests skip, saying so; CI installs both (see CONTRIBUTING.md)."""

from __future__ import annotations

import os
import re
import time

import pytest

from rig.testing import Child, client_config, close_browser, serve_sim, watch
from sessions import read_session

from .cli import rig_here
from .conftest import digest
from .forcfiles import Relays, forc_data, lines_0016, write_lines
from .watchkit import browser_or_skip, session_fds, svg_texts, wait_page

pytestmark = [pytest.mark.timeout(180), pytest.mark.slow]


@pytest.fixture(scope="module")
def browser():
    drv = browser_or_skip()
    yield drv
    close_browser(drv)


def text(drv, element_id: str) -> str:
    return drv.find_element("id", element_id).text


def points_shown(drv) -> int:
    """The applied-point count the page shows ("17 of 38 (44.7 %)"), -1 before there is one."""
    m = re.match(r"(\d+) of (\d+)", text(drv, "points"))
    return int(m.group(1)) if m else -1


def test_a_live_run_seen_in_the_browser_as_it_is_written(tmp_path, browser):
    path = tmp_path / "live.h5"
    server = serve_sim(tmp_path)
    try:
        with watch(path) as w:  # started with the run, it waits for the file to be created
            # L = 6: 23 points, a fifth of a second each on the real clock
            child = Child("--config", client_config(server, tmp_path), "--levels", 6, "--dwell", 0.2,
                          "--readings", 1, "--out", path)
            browser.get(w.ready["url"])
            wait_page(browser, lambda d: points_shown(d) > 0, what="a point count")
            assert text(browser, "title") == "live.h5" and "live.h5" in browser.title
            assert text(browser, "status") == "RUNNING" and "being written now" in text(browser, "status-text")
            # the watcher holds the session open for reading only, while the writer writes it
            modes = session_fds(w.proc.pid, path)
            assert modes and all(m == 0 for m in modes), modes  # O_RDONLY
            first = points_shown(browser)
            wait_page(browser, lambda d: points_shown(d) >= first + 3, what="the point count growing")
            # the loop, drawn with labelled axes in the session's units, and redrawn as samples arrive
            labels = wait_page(browser, lambda d: svg_texts(d, "loop"), what="the loop figure")
            assert "heater voltage (V)" in labels and "deflection (µm)" in labels
            drawn = browser.execute_script("return window.rigWatch.figures.loop")
            wait_page(browser, lambda d: d.execute_script("return window.rigWatch.figures.loop") > drawn,
                      what="the loop redrawn")
            assert {"heater voltage (V)", "deflection (µm)", "time (s)"} <= set(svg_texts(browser, "time"))
            code, _, err = child.finish()
            assert code == 0, err
            written = digest(path)
            wait_page(browser, lambda d: text(d, "status") == "COMPLETE", what="the run complete")
            assert points_shown(browser) == 23 and "23 of 23 planned" in text(browser, "measured")
            model = wait_page(browser, lambda d: "of the first 23" in text(d, "model-text") and text(d, "model-text"),
                              what="the model fitted on the whole run")
            assert model.startswith("smooth_nn, L = 6, fitted on 23 measured points")
            assert "model" in svg_texts(browser, "loop")  # the model's path is in the loop's legend
            # the model's figure is drawn after its text: wait for it (bounded) rather than race it
            wait_page(browser, lambda d: any(t.startswith("residual") for t in svg_texts(d, "model")),
                      what="the model's residual figure")
            browser.save_screenshot(str(tmp_path / "live.png"))
            time.sleep(0.6)  # more polls of the finished file, with the page open
        assert digest(path) == written  # watching never wrote a byte
        assert read_session(path).n_samples == 23
    finally:
        server.stop()


def group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def forc_session(tmp_path):
    relays = Relays.random(40, -0.09, 0.09, seed=3, bias=0.25, slope=2.0)
    data = forc_data(relays, [0.02, 0.0, -0.02, -0.04, -0.06], 0.01, 0.06, {"elapsed": 120.0})
    out = tmp_path / "forc.h5"
    run = rig_here("import", "--format", "micromag", write_lines(tmp_path / "m.forc", lines_0016(data)), "--out", out)
    assert run.code == 0, run.err
    return out


def test_beyond_loopback_the_page_needs_the_printed_token_and_shows_a_forc_session_in_its_units(tmp_path, browser):
    path = forc_session(tmp_path)
    with watch(path, "--host", "0.0.0.0", "--allow-remote") as w:
        token, port = w.ready["token"], w.ready["port"]
        assert token and w.ready["url"].endswith(f":{port}/?token={token}")
        wait_page(None, lambda _: "access token" in w.err, what="the token's notice on stderr")
        assert w.err.count(token) == 1  # printed once, on stderr, besides the URL on stdout
        base = f"http://127.0.0.1:{port}/"
        browser.get(base)
        assert "Access token needed" in browser.find_element("tag name", "h1").text
        browser.get(f"{base}?token=not-{token}")
        assert "Access token needed" in browser.find_element("tag name", "h1").text
        browser.get(f"{base}?token={token}")
        wait_page(browser, lambda d: text(d, "status") == "COMPLETE", what="the session's page")
        assert browser.current_url == base  # the token went into a cookie, out of the address bar
        assert browser.execute_script("return document.cookie") == ""  # which scripts cannot read
        # an imported FORC measurement: field in T, moment in A·m², as the session records them
        labels = wait_page(browser, lambda d: svg_texts(d, "loop"), what="the loop figure")
        assert "applied field (T)" in labels and "magnetic moment (A·m²)" in labels
        assert "magnetic moment (A·m²)" in svg_texts(browser, "time")
        # Ctrl-C ends the watch, exit code 0, and soon every process it started (its whole process group)
        assert w.stop() == 0 and "rig watch: stopped" in w.err
        wait_page(None, lambda _: not group_alive(w.proc.pid), timeout=10, what="the watch's processes gone")
    browser.delete_all_cookies()
