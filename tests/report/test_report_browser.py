"""The demo report with a design, as a browser shows it and as it prints.

Headless Chromium (Debian's /usr/bin/chromium, driven by Playwright) takes the screenshots an
instructor would look at — the first page and the controller section — into
``tests/artefacts/report-*.png``, and prints the page to A4: every page is A4, nothing is
wider than the paper, and no figure is cut by a page break.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from motorid.report import SECTIONS

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

ARTEFACTS = Path(__file__).resolve().parents[1] / "artefacts"
#: A4 in PostScript points (1/72 in): 210 × 297 mm.
A4_PT = (595.3, 841.9)
#: CSS pixels per millimetre (96 px per inch).
PX_PER_MM = 96 / 25.4
#: The print margins of the page's @page rule (mm) and the text width they leave.
MARGIN_MM = 12
TEXT_WIDTH_PX = (210 - 2 * MARGIN_MM) * PX_PER_MM
TEXT_HEIGHT_PX = (297 - 2 * MARGIN_MM) * PX_PER_MM


@pytest.fixture(scope="module")
def chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no Chromium: install Debian's package 'chromium' (.ci/run does)")
    pytest.importorskip("playwright.sync_api", reason="playwright (Python) is not installed: pip install -e '.[test]'")
    return exe


@pytest.fixture(scope="module")
def report_with_design(demo_run, tmp_path_factory) -> Path:
    """The demo's identification with a design (ζ 0.7, ωn 5) and the trainer's truth."""
    import motorid as mi
    from motorid.io import read_capture
    from motorid.report.assemble import make_report

    ident = demo_run.result.identification
    folder = demo_run.folder
    captures = {role: read_capture(folder / f"ALL{i:04d}") for i, role in enumerate(("position", "velocity", "current"))}
    checks = {name: read_capture(folder / f"ALL{i:04d}") for i, name in ((3, "sine"), (4, "triangle"), (5, "square"))}
    design = mi.design(ident.model, damping=0.7, wn=5.0).to_json()
    html = make_report(ident, captures, validation=checks, design=design, truth=demo_run.truth,
                       title="motorid demo: virtual trainer, seed 0")
    path = tmp_path_factory.mktemp("report") / "report.html"
    path.write_text(html, encoding="utf-8")
    return path


def test_report_screenshots_and_a4_print(chromium, report_with_design, tmp_path):
    from playwright.sync_api import sync_playwright

    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    errors: list[str] = []
    requests: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1000, "height": 1400})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("request", lambda r: requests.append(r.url) if not r.url.startswith(("file:", "data:")) else None)
        page.goto(report_with_design.as_uri())
        for sid in SECTIONS:
            assert page.locator(f"section#{sid}").count() == 1, sid
        assert page.locator("#guide").is_visible()
        page.screenshot(path=str(ARTEFACTS / "report-first-page.png"))
        page.locator("section#design").screenshot(path=str(ARTEFACTS / "report-design.png"))

        # figures are shown full width on screen: as wide as their section
        widths = page.eval_on_selector_all(
            "figure img", "els => els.map(e => [e.getBoundingClientRect().width, e.closest('section').clientWidth])")
        assert len(widths) >= 10 and all(abs(w - s) < 2 for w, s in widths), widths

        # print: A4 media, nothing wider than the text width, and the PDF's pages are A4
        page.emulate_media(media="print")
        page.set_viewport_size({"width": round(TEXT_WIDTH_PX), "height": 1000})
        overflow = page.evaluate("document.documentElement.scrollWidth - document.documentElement.clientWidth")
        assert overflow <= 0, f"the printed page is {overflow} px wider than the A4 text width"
        # every figure fits on one page, so that its break-inside: avoid can keep it whole
        heights = page.eval_on_selector_all("figure", "els => els.map(e => e.getBoundingClientRect().height)")
        assert max(heights) < TEXT_HEIGHT_PX, (max(heights), TEXT_HEIGHT_PX)
        pdf = tmp_path / "report.pdf"
        page.pdf(path=str(pdf), prefer_css_page_size=True, print_background=True)
        browser.close()
    assert not errors, errors
    assert not requests, requests  # self-contained: no network

    data = pdf.read_bytes()
    boxes = {tuple(round(float(v), 1) for v in m) for m in
             re.findall(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", data)}
    assert boxes and all(abs(w - A4_PT[0]) < 1 and abs(h - A4_PT[1]) < 1 for w, h in boxes), boxes
    pages = len(re.findall(rb"/Type\s*/Page[^s]", data))
    assert 6 <= pages <= 20, pages
    # a look at the print itself (poppler's pdftoppm, when installed): page 1 as an image
    if shutil.which("pdftoppm"):
        subprocess.run(["pdftoppm", "-png", "-r", "60", "-f", "1", "-l", "2", str(pdf),
                        str(ARTEFACTS / "report-print")], check=True, timeout=60)


def test_report_page_of_the_demo_shows_the_truth_against_the_interval(report_with_design, demo_run):
    html = report_with_design.read_text(encoding="utf-8")
    summary = html[html.index('<section id="summary">'):html.index('<section id="captures">')]
    assert 'alt="estimates against their intervals"' in summary
    # each quantity: inside or outside its interval as the model's own numbers say (independent check)
    from motorid.report.truth import QUANTITIES

    model, first = demo_run.result.identification.model, demo_run.truth["transfer_functions"]["first_order"]
    for key, words, _ in QUANTITIES:
        if key not in first:  # the truth gives dc gain and τ by moments; the 63 % time is the classic's
            continue
        lo, hi = model.uncertainty[key]["ci95"]
        inside = lo <= first[key] <= hi
        assert (f"lies inside the 95 % interval of the {words}" in summary) == inside, key
        assert (f"standard errors above the {words}" in summary or f"standard errors below the {words}"
                in summary) == (not inside), key
    # the demo's gain misses the linearised truth by far more than its interval: the trainer's
    # friction (an input offset of 0.1 V on a 5.92 V step) is named as the cause
    gain = model.uncertainty["dc_gain"]
    assert (first["dc_gain"] - gain["value"]) / gain["std"] > 10
    assert "input offset of 0.1 V" in summary and "1.7 % below the linearised truth" in summary
    design = html[html.index('<section id="design">'):]
    assert "rails ±10 V" in design and "Kp in V/V" in design and "V/(V/s)" in design
    assert "settling time (2 %)" in design


def test_a_load_disturbance_is_marked_on_the_closed_loop(demo_run, monkeypatch):
    """make_report(simulation=...) runs the design with a brake load: the page marks the
    instant, the figure draws it, and the rails are the run's own."""
    import numpy as np

    import motorid as mi
    from motorid.io import read_capture
    from motorid.report import figures
    from motorid.report.assemble import make_report
    from motorid.simulation.closed_loop import SimulationSettings

    kept = []
    real_png = figures.png
    monkeypatch.setattr(figures, "png", lambda fig: kept.append(fig) or real_png(fig))
    ident = demo_run.result.identification
    captures = {role: read_capture(demo_run.folder / f"ALL{i:04d}")
                for i, role in enumerate(("position", "velocity", "current"))}
    design = mi.design(ident.model, damping=0.7, wn=5.0, integral=True).to_json()
    run = SimulationSettings(duration_s=4.0, saturation_v=8.0, disturbance_v=1.0, disturbance_start_s=2.5)
    html = make_report(ident, captures, design=design, sweep=False, simulation=run)
    section = html[html.index('<section id="design">'):]
    assert "rails ±8 V" in section and "the instants a load is applied" in section
    loop = next(f for f in kept if f.axes and f.axes[-1].get_ylabel() == "control u (V)")
    for ax in loop.axes[:2]:
        assert any(len(ln.get_xdata()) == 2 and np.allclose(ln.get_xdata(), 2.5) for ln in ax.get_lines())
    assert any(len(ln.get_ydata()) == 2 and np.allclose(ln.get_ydata(), 8.0) for ln in loop.axes[1].get_lines())
