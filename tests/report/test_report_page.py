"""The HTML report of the demo experiment, and ``motorid validate``."""

import re
import shutil
import subprocess

import pytest

from motorid.report import SECTIONS

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def demo(demo_run):
    return demo_run.folder


def test_demo_writes_a_self_contained_report(demo):
    page = (demo / "report.html").read_text(encoding="utf-8")
    for sid in SECTIONS:
        assert f'<section id="{sid}">' in page, sid
    assert "not available" not in page  # every section could be drawn
    # self-contained: no script, no external resource of any kind
    assert "<script" not in page.lower()
    assert not re.search(r'(src|href)\s*=\s*"(https?:)?//', page)
    imgs = re.findall(r'<img [^>]*src="([^"]{0,30})', page)
    assert len(imgs) >= 8 and all(s.startswith("data:image/png;base64,") for s in imgs)
    assert "@media print" in page
    # the demo's 8-bit pot is not dithered by its noise: the report says how it was used
    assert "noise model of the output-error fit" in page
    assert "its scale only" in page


@pytest.mark.browser  # the browser files (*_browser.py) are marked by tests/conftest.py
def test_report_renders_in_headless_chromium(demo):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian package 'chromium'); .ci/run installs it")
    page = demo / "report.html"
    proc = subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
         "--host-resolver-rules=MAP * ~NOTFOUND", "--dump-dom", page.as_uri()],
        capture_output=True, text=True, timeout=120,
    )
    dom = proc.stdout
    for sid in SECTIONS:
        assert f'id="{sid}"' in dom, sid
    console = [ln for ln in proc.stderr.splitlines() if "CONSOLE" in ln or "Uncaught" in ln]
    network = [ln for ln in proc.stderr.splitlines() if "net::ERR" in ln]
    assert not console, console
    assert not network, network


def test_validate_command_scores_the_test_signals(demo, run_cli):
    caps = [demo / f"ALL{i:04d}" for i in (3, 4, 5)]
    res = run_cli("validate", demo / "model.json", *caps, "--json")
    assert res.code == 0, res.err
    import json

    rows = json.loads(res.out)
    assert len(rows) == 3
    # the demo model follows the sine, triangle and square runs closely (paper Figs. 36-38)
    assert all(r["nrmse"] < 0.1 for r in rows), rows
    res = run_cli("validate", demo / "model.json", *caps, "--max-nrmse", "1e-6")
    assert res.code == 3 and "above --max-nrmse" in res.err


def test_validate_bad_model_json_is_one_line(tmp_path, demo, run_cli):
    bad = tmp_path / "m.json"
    bad.write_text('{"schema": "other"}')
    res = run_cli("validate", bad, demo / "ALL0003")
    assert res.code == 2 and "m.json" in res.err and len(res.err.strip().splitlines()) == 1


def test_identify_report_with_design_shows_closed_loop_and_modes(demo, run_cli, tmp_path):
    m, d, page = tmp_path / "m.json", tmp_path / "d.json", tmp_path / "r.html"
    common = ("--velocity", demo / "ALL0001", "--position", demo / "ALL0000", "--method", "pinv", "--order", "2")
    assert run_cli("identify", *common, "--json", m).code == 0
    res = run_cli("design", m, "--damping", "1", "--k2", "2", "--json", d)
    assert res.code == 0, res.err
    res = run_cli("identify", *common, "--report", page, "--design", d, "--validate", demo / "ALL0003")
    assert res.code == 0, res.err
    html = page.read_text(encoding="utf-8")
    design = html[html.index('<section id="design">'):]
    assert 'alt="closed loop"' in design and 'alt="mode map"' in design and "settling time (2 %)" in design
    assert 'alt="ALL0003"' in html  # the validation overlay
    # the loop's margins, in the gains table and as Bode and Nyquist plots
    assert 'alt="loop Bode and Nyquist"' in design and "phase margin" in design and "Ms " in design


def test_report_simulates_a_design_made_on_the_default_model(demo, run_cli, tmp_path):
    """The chain as a user runs it with default options — the demo's own model
    (output-error states x1..x3), a design on it in measurable coordinates, and the report
    of the same identification must show the closed loop, not a note that it cannot."""
    d, page = tmp_path / "d.json", tmp_path / "r.html"
    res = run_cli("design", demo / "model.json", "--damping", "0.7", "--wn", "5", "--json", d)
    assert res.code == 0, res.err
    res = run_cli("identify", "--velocity", demo / "ALL0001", "--position", demo / "ALL0000",
                  "--current", demo / "ALL0002", "--report", page, "--design", d)
    assert res.code == 0, res.err
    html = page.read_text(encoding="utf-8")
    design = html[html.index('<section id="design">'):]
    assert 'alt="closed loop"' in design and "cannot be simulated" not in design
    # the design on the plausible motors: its line and its band of steps
    assert "plausible motors" in design and 'alt="on plausible motors"' in design


def test_report_of_a_fast_motor_without_input_channel_has_every_section(tmp_path, run_cli):
    """A 16 ms motor on a TBS1000, tacho + shunt, no input channel, 0.35 s of record: the
    sensitivity table uses the data's own grid (the paper's lengths are longer than the record)
    and the user's --step-volts."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("fast-tbs1000", tmp_path / "rec", seed=2)
    page = tmp_path / "r.html"
    res = run_cli("report", "--out", page, *[str(a) for a in rec.cli_args])
    assert res.code == 0, res.err
    html = page.read_text(encoding="utf-8")
    for sid in SECTIONS:
        assert f'<section id="{sid}">' in html, sid
    assert 'alt="sensitivity maps"' in html


def test_figures_leave_the_callers_matplotlib_backend_alone(tmp_path):
    """No ``matplotlib.use("Agg")`` in library code: a notebook's backend stays."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(
        f"""
        import matplotlib
        matplotlib.use("pdf")
        from motorid.cli.demo import run_demo
        run_demo({str(tmp_path / 'D')!r}, seed=5)
        from motorid.simulation.modes import ModeCriteria, mode_map, plot_mode_maps, servo_plants
        from motorid.model import MotorModel
        import json, numpy as np
        m = MotorModel.from_json(json.load(open({str(tmp_path / 'D' / 'model.json')!r})))
        maps = tuple(mode_map(p, np.linspace(1, 20, 5), np.linspace(0, 4, 5), ModeCriteria()) for p in servo_plants(m))
        plot_mode_maps(maps, {str(tmp_path / 'm.png')!r})
        print(matplotlib.get_backend())
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "pdf"
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"
