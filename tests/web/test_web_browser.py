"""The page in a real headless Chromium (Playwright driving Debian's /usr/bin/chromium):
upload the demo captures, wait for the model, move a slider, see the plot change, download
the report.  Screenshots are kept in tests/artefacts/web/."""

from __future__ import annotations

import re
import shutil
import socket
import threading
import time
from pathlib import Path

import pytest
from webhelpers import ARTEFACTS

from motorid.report import SECTIONS

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

CHROMIUM = Path("/usr/bin/chromium")


@pytest.fixture(scope="module")
def chromium() -> str:
    exe = str(CHROMIUM) if CHROMIUM.exists() else shutil.which("chromium")
    if exe is None:
        pytest.skip("no Chromium: install Debian's package 'chromium' (.ci/run does); Playwright's own browser "
                    "download is not used")
    pytest.importorskip("playwright.sync_api", reason="playwright (Python) is not installed: pip install -e '.[test]'")
    return exe


@pytest.fixture
def live_server(tmp_path):
    """The app under uvicorn in a thread on a free port; stopped (and its folder gone) afterwards."""
    import uvicorn

    from motorid.web import WebSettings, create_app

    root = tmp_path / "root"
    root.mkdir()
    app = create_app(WebSettings(temp_root=root))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:  # a condition polled, with a deadline
        assert thread.is_alive() and time.monotonic() < deadline, "uvicorn did not start"
        time.sleep(0.02)
    yield f"http://127.0.0.1:{port}", app, root
    server.should_exit = True
    thread.join(timeout=30)
    assert list(root.iterdir()) == []  # the server's temporary folder went with it


def test_lab_page_in_headless_chromium(chromium, live_server, demo_files):
    from playwright.sync_api import sync_playwright

    url, app, root = live_server
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    console: list[str] = []
    foreign: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        context = browser.new_context(viewport={"width": 1280, "height": 900}, accept_downloads=True)
        page = context.new_page()
        page.on("console", lambda m: console.append(m.text) if m.type == "error" else None)
        page.on("request", lambda r: foreign.append(r.url) if not r.url.startswith((url, "data:")) else None)
        page.goto(url + "/")
        assert len(app.state.tabs) == 1

        # 1. drop the demo's twelve files (the file input behind the drop zone)
        page.set_input_files("#files", [str(f) for f in demo_files])
        page.wait_for_selector("#inspect-table tr#row-c5", timeout=60_000)
        roles = [page.input_value(f"select[name=role_c{i}]") for i in range(6)]
        assert roles == ["position", "velocity", "current", "validation", "validation", "validation"]
        page.screenshot(path=str(ARTEFACTS / "1-captures.png"), full_page=True)

        # 2. identify; the indicator shows while it runs; wait for the model and the first design
        page.click("#identify-button")
        page.wait_for_selector("#model-panel", timeout=120_000)
        page.wait_for_selector("#closed-loop-plot", timeout=60_000)
        assert page.locator("#params tr").count() >= 3
        page.screenshot(path=str(ARTEFACTS / "2-model.png"), full_page=True)

        # 3. move the ωn slider with the keyboard, as a user would; the plot and the marker follow
        before = page.get_attribute("#closed-loop-plot", "src")
        marker_before = page.get_attribute("#mode-map circle.marker", "cx")
        kp_before = float(page.get_attribute("#design-view", "data-kp"))
        page.focus("#wn")
        t0 = page.evaluate("performance.now()")
        for _ in range(25):
            page.keyboard.press("ArrowRight")
        page.wait_for_function("src => document.querySelector('#closed-loop-plot').getAttribute('src') !== src",
                               arg=before, timeout=30_000)
        # the page settles on the slider's last position (requests are queued, the last one kept)
        page.wait_for_function("() => Number(document.querySelector('#design-view').dataset.wn) === "
                               "Number(document.querySelector('#wn').value)", timeout=30_000)
        elapsed_ms = page.evaluate("performance.now()") - t0
        # the panel's busy line is wired to the form and gone once the page has settled
        assert page.get_attribute("#design-form", "hx-indicator") == "#design-busy"
        page.wait_for_selector("#design-busy", state="hidden", timeout=10_000)
        assert page.get_attribute("#closed-loop-plot", "src") != before
        assert float(page.get_attribute("#design-view", "data-kp")) > kp_before  # faster poles: larger gain
        assert page.get_attribute("#mode-map circle.marker", "cx") != marker_before
        wn_shown = float(page.text_content("#wn + output"))
        assert wn_shown == pytest.approx(float(page.input_value("#wn")))
        (ARTEFACTS / "slider_roundtrip_ms.txt").write_text(f"{elapsed_ms:.0f} ms from the first of 25 key presses until the page shows the last position\n")
        page.screenshot(path=str(ARTEFACTS / "3-design.png"), full_page=True)
        page.set_viewport_size({"width": 1280, "height": 1560})
        page.evaluate("document.querySelector('#design-form').scrollIntoView()")
        page.screenshot(path=str(ARTEFACTS / "4-controller.png"))  # the view docs/web.md shows

        # integral action and an observer (the placeholder's example poles, one per state):
        # text fields update on change, not on every key
        page.check("input[name=integral]")
        page.wait_for_selector("#gains td:text-is('ki')", timeout=30_000)
        example = page.get_attribute("input[name=observer_poles]", "placeholder").split("e.g. ")[1]
        assert len(example.split(",")) == len(page.locator("#gains tr").all()) - 2  # header and ki rows
        page.fill("input[name=observer_poles]", example)
        page.press("input[name=observer_poles]", "Tab")
        page.wait_for_selector("#gains td:text-is('L')", timeout=30_000)
        assert page.text_content("#errors").strip() == ""

        # 4. download the report (with the design) and the design JSON
        with page.expect_download(timeout=120_000) as dl:
            page.click("#dl-report")
            # the report takes seconds to write: a busy line with its elapsed time says so
            busy = page.wait_for_selector("#dl-report + .busy", timeout=10_000)
            assert "writing the report" in busy.text_content()
        page.wait_for_selector("#dl-report + .busy", state="detached", timeout=30_000)
        report = Path(dl.value.path()).read_text(encoding="utf-8")
        assert dl.value.suggested_filename == "motorid-report.html"
        for sid in SECTIONS:
            assert f'<section id="{sid}">' in report, sid
        assert "no controller design given" not in report
        # the files by the names they were uploaded under, never the server's folders; in the
        # text, not in the figures' base64 (860 kB of it: "/tmp" turns up by chance in 1 report of 20)
        text = re.sub(r"data:[\w/+.-]+;base64,[A-Za-z0-9+/=]+", "data:…", report)
        assert str(root) not in text
        assert "/tmp" not in text
        assert "F0001CH2.CSV" in text
        with page.expect_download() as dl:
            page.click("#dl-design")
        assert '"schema": "motorid.design/1"' in Path(dl.value.path()).read_text(encoding="utf-8")

        # 5. closing the tab deletes its folder (the pagehide beacon)
        page.close(run_before_unload=True)
        deadline = time.monotonic() + 10
        while len(app.state.tabs) and time.monotonic() < deadline:  # the beacon is asynchronous
            time.sleep(0.05)
        assert len(app.state.tabs) == 0
        context.close()
        browser.close()
    assert console == [], console[:5]
    assert foreign == []


EVIL_PAGE = """<!DOCTYPE html><html><body><script>
const target = "%(target)s";
async function attack() {
  const tries = [
    fetch(target + "/", {mode: "no-cors", credentials: "include"}),
    fetch(target + "/api/design", {method: "POST", mode: "no-cors", credentials: "include",
          headers: {"Content-Type": "text/plain"}, body: '{"model": {}, "damping": 0.7, "wn": 5}'}),
    fetch(target + "/api/identify", {method: "POST", mode: "no-cors", credentials: "include",
          body: new FormData()}),
  ];
  await Promise.allSettled(tries);
  document.title = "done";
}
attack();
</script></body></html>"""


def test_a_page_from_another_origin_gets_nothing_while_the_real_page_works(chromium, tmp_path):
    """The server with its token; a page served from another origin (another port: another site to
    the browser) tries the requests a hostile page would; each is refused, and the real page,
    opened at the address serve prints, works in the same browser."""
    import functools
    import http.server

    import uvicorn
    from playwright.sync_api import sync_playwright

    from motorid.web import WebSettings, create_app

    root = tmp_path / "root"
    root.mkdir()
    token = "t0ken-for-the-test"
    app = create_app(WebSettings(temp_root=root, token=token))
    ports = []
    for _ in range(2):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            ports.append(s.getsockname()[1])
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=ports[0], log_level="warning"))
    threading.Thread(target=server.run, daemon=True).start()
    evil_dir = tmp_path / "evil"
    evil_dir.mkdir()
    target = f"http://127.0.0.1:{ports[0]}"
    (evil_dir / "index.html").write_text(EVIL_PAGE % {"target": target})
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(evil_dir))
    evil = http.server.ThreadingHTTPServer(("127.0.0.1", ports[1]), handler)
    threading.Thread(target=evil.serve_forever, daemon=True).start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert time.monotonic() < deadline, "uvicorn did not start"
        time.sleep(0.02)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            context = browser.new_context()
            # the user's own page first: the token cookie is in the browser when the evil page runs
            real = context.new_page()
            assert real.goto(f"{target}/?token={token}").status == 200
            assert len(app.state.tabs) == 1
            seen: list[tuple[str, int]] = []
            page = context.new_page()
            page.on("response", lambda r: seen.append((r.url, r.status)) if r.url.startswith(target) else None)
            page.goto(f"http://localhost:{ports[1]}/index.html")
            page.wait_for_function("document.title === 'done'", timeout=30_000)
            page.wait_for_timeout(300)
            statuses = dict(seen)
            # the SameSite=Strict cookie stays home: the page is not served, no tab is opened
            assert statuses.get(f"{target}/") == 403, statuses
            assert len(app.state.tabs) == 1
            assert statuses.get(f"{target}/api/design") == 403, statuses
            assert statuses.get(f"{target}/api/identify") == 403, statuses
            # the real page still works after the attempt
            assert real.reload().status == 200
            browser.close()
    finally:
        server.should_exit = True
        evil.shutdown()


def test_the_page_never_shows_a_result_of_other_captures(chromium, live_server, demo_files):
    """Captures → model → design as one chain: clearing or replacing the captures, or a failed
    identification, leaves no older model on screen (screenshots in tests/artefacts/web/state-*)."""
    from playwright.sync_api import sync_playwright

    url, _, _ = live_server
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.goto(url + "/")
        page.set_input_files("#files", [str(f) for f in demo_files])
        page.wait_for_selector("#inspect-table tr#row-c5", timeout=60_000)
        page.click("#identify-button")
        page.wait_for_selector("#model-panel", timeout=120_000)
        page.wait_for_selector("#closed-loop-plot", timeout=60_000)
        page.screenshot(path=str(ARTEFACTS / "state-1-model.png"), full_page=True)

        # a failed identification (no capture in the velocity or position role) takes the old model away
        for i in range(6):
            page.select_option(f"select[name=role_c{i}]", "validation")
        page.click("#identify-button")
        page.wait_for_selector("#errors p.error", timeout=60_000)
        assert "no capture has the role velocity or position" in page.text_content("#errors")
        assert page.locator("#model-panel").count() == 0 and page.locator("#closed-loop-plot").count() == 0
        page.screenshot(path=str(ARTEFACTS / "state-2-failed.png"), full_page=True)

        # the right roles again: a model; then new captures: the model goes until identified again
        for i, role in enumerate(("position", "velocity", "current")):
            page.select_option(f"select[name=role_c{i}]", role)
        page.click("#identify-button")
        page.wait_for_selector("#model-panel", timeout=120_000)
        assert page.text_content("#errors").strip() == ""
        page.set_input_files("#files", [str(f) for f in demo_files[:2]])
        page.wait_for_selector("#inspect-table tr#row-c6", timeout=60_000)
        assert page.locator("#model-panel").count() == 0
        page.screenshot(path=str(ARTEFACTS / "state-3-new-captures.png"), full_page=True)

        # clearing the captures clears the model and the design with them
        page.click("#identify-button")
        page.wait_for_selector("#model-panel", timeout=120_000)
        page.click("text=Clear captures")
        page.wait_for_selector("#inspect-table", state="detached", timeout=30_000)
        assert page.locator("#model-panel").count() == 0 and page.locator("#design-form").count() == 0
        assert page.locator("#dl-report").count() == 0  # no download link to a model that is gone
        page.screenshot(path=str(ARTEFACTS / "state-4-cleared.png"), full_page=True)
        browser.close()
