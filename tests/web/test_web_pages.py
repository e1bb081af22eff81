"""The page's endpoints with fastapi.testclient — upload → inspect → identify →
design → downloads — checked against the front door run on the same files."""

from __future__ import annotations

import html
import json
import io
import re
import zipfile

import numpy as np
import pytest
from webhelpers import multipart, open_tab

import motorid as mi
from motorid.cli.demo import CAPTURE_ORDER
from motorid.report import SECTIONS

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

ROLES = {"c0": "position", "c1": "velocity", "c2": "current", "c3": "validation", "c4": "validation",
         "c5": "validation"}


def _roles_in(html: str) -> dict[str, str]:
    return dict(re.findall(r'name="role_(c\d+)".*?<option value="(\w+)" selected', html, re.S))


def test_page_ships_every_asset_and_opens_a_tab_folder(client, web_root):
    page = client.get("/")
    assert page.status_code == 200
    tab = re.search(r'data-tab="([0-9a-f]{32})"', page.text).group(1)
    # no internet needed: every script and style is served by the app itself
    assert not re.search(r'(src|href)\s*=\s*"(https?:)?//', page.text)
    for asset in re.findall(r'(?:src|href)="(/static/[^"]+)"', page.text):
        assert client.get(asset).status_code == 200, asset
    assert "htmx" in client.get("/static/htmx.min.js").text[:200]
    folders = [p.name for p in next(web_root.iterdir()).iterdir()]
    assert folders == [f"tab-{tab}"]


def test_upload_pairs_channel_files_and_guesses_roles(client, demo_files):
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files))
    assert res.status_code == 200, res.text
    # six captures, each a CH1 + CH2 pair, in the demo's order; roles as the trainer recorded them
    labels = re.findall(r"<code>(F\d{4}CH1\.CSV \+ F\d{4}CH2\.CSV)</code>", res.text)
    assert labels == [f"F{i:04d}CH1.CSV + F{i:04d}CH2.CSV" for i in range(6)]
    truth = {f"c{i}": (name if name in ("position", "velocity", "current") else "validation")
             for i, name in enumerate(CAPTURE_ORDER)}
    assert _roles_in(res.text) == truth


def test_upload_zip_of_scope_folders(client, demo_files, tmp_path):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for p in demo_files[:6]:  # ALL0000..ALL0002
            zf.write(p, f"lab/{p.parent.name}/{p.name}")
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=[("files", ("lab.zip", buf.getvalue(), "application/zip"))])
    assert res.status_code == 200, res.text
    labels = re.findall(r"<code>([^<]+)</code>", res.text.split('id="inspect-table"')[1])[:3]
    # members keep their scope folder, under a folder named after the zip
    assert labels == [f"lab/ALL{i:04d}/F{i:04d}CH1.CSV + F{i:04d}CH2.CSV" for i in range(3)]
    assert _roles_in(res.text) == {"c0": "position", "c1": "velocity", "c2": "current"}


@pytest.fixture(scope="module")
def demo_fit(demo_run):
    """The front door on the same files: the independent computation the page is checked against."""
    d = demo_run.folder
    exp = mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001", current=d / "ALL0002")
    return mi.identify(exp)


def _identified_tab(client, demo_files, page: list | None = None) -> str:
    tab = open_tab(client)
    assert client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files)).status_code == 200
    form = {f"role_{k}": v for k, v in ROLES.items()} | {"method": "auto", "order": "auto", "delay": "auto"}
    res = client.post(f"/tab/{tab}/identify", data=form)
    assert res.status_code == 200, res.text
    if page is not None:
        page.append(res.text)
    return tab


def test_identify_design_and_downloads_match_the_front_door(client, demo_files, demo_fit):
    pages: list[str] = []
    tab = _identified_tab(client, demo_files, pages)
    page = pages[0]
    model = client.get(f"/tab/{tab}/download/model.json")
    assert model.status_code == 200
    assert 'filename="motorid-model.json"' in model.headers["content-disposition"]
    got, want = model.json(), demo_fit.to_json()
    assert got["method"] == want["method"] and got["states"] == want["states"]
    for key in ("dc_gain", "time_constant"):  # same files, same options: the same numbers
        assert got["first_order"][key] == pytest.approx(want["first_order"][key], rel=1e-9)
    script = client.get(f"/tab/{tab}/download/model.m").text
    assert script == demo_fit.model.to_matlab()

    res = client.post(f"/tab/{tab}/design", data={"damping": "0.8", "wn": "6", "saturation": "10", "level": "5",
                                                  "duration": "3"})
    assert res.status_code == 200, res.text
    assert re.match(r"update;dur=\d", res.headers["server-timing"])
    design = client.get(f"/tab/{tab}/download/design.json").json()
    ref = mi.design(demo_fit.model, damping=0.8, wn=6.0).to_json()
    np.testing.assert_allclose(design["K"], ref["K"], rtol=1e-9)
    sim = mi.simulate(demo_fit.model, mi.design(demo_fit.model, damping=0.8, wn=6.0), duration_s=3.0,
                      level_v=5.0, saturation=10.0)
    shown = re.search(r"overshoot</td><td>([^ ]+) %", res.text).group(1)
    assert float(shown) == pytest.approx(sim.metrics.overshoot_pct, rel=1e-2, abs=1e-3)
    # the report downloaded now shows the run the page showed (its horizon, level and rails: the
    # report's own 5 s step of 5 V with ±10 V rails gives another overshoot for this design)
    res = client.post(f"/tab/{tab}/design", data={"damping": "0.4", "wn": "3", "saturation": "2", "level": "4",
                                                  "duration": "1.5"})
    shown = re.search(r"overshoot</td><td>([^ ]+) %", res.text).group(1)
    in_report = re.search(r"overshoot</td><td>([^ ]+) %", client.get(f"/tab/{tab}/download/report.html").text)
    assert float(in_report.group(1)) == pytest.approx(float(shown), rel=1e-3), (in_report.group(1), shown)
    default = mi.simulate(demo_fit.model, mi.design(demo_fit.model, damping=0.4, wn=3.0), duration_s=5.0,
                          level_v=5.0, saturation=10.0)
    assert abs(default.metrics.overshoot_pct - float(shown)) > 1.0  # the check can fail
    # the mode map: the library's SVG plus one marker per map, its mode read off the map
    assert res.text.count('<circle class="marker') == 2
    assert re.search(r"on the 2nd order map", res.text)

    # integral action and an observer (the placeholder's example: one pole per state)
    example = re.search(r'name="observer_poles" placeholder="none, e.g. ([^"]+)"', page).group(1)
    res = client.post(f"/tab/{tab}/design", data={"damping": "0.8", "wn": "6", "integral": "on",
                                                  "observer_poles": example, "saturation": "10"})
    assert res.status_code == 200, res.text
    ref = mi.design(demo_fit.model, damping=0.8, wn=6.0, integral=True,
                    observer_poles=[complex(p) for p in example.split(",")])
    shown_l = re.search(r'<td class="l">L</td><td colspan="2">([^<]+)</td>', res.text).group(1)
    np.testing.assert_allclose([float(v) for v in shown_l.split(",")], ref.L, rtol=1e-3)  # shown with 4 digits
    assert client.get(f"/tab/{tab}/download/design.json").json()["ki"] == pytest.approx(ref.ki, rel=1e-9)

    report = client.get(f"/tab/{tab}/download/report.html")
    assert report.status_code == 200
    for sid in SECTIONS:
        assert f'<section id="{sid}">' in report.text, sid
    assert "no controller design given" not in report.text  # the design went into the report
    assert "no validation captures given" not in report.text  # the sine/triangle/square went in


def test_slider_moves_change_the_design(client, demo_files):
    # the time per update is measured by bench/web_update_speed.py (a timing asserted here would flake)
    tab = _identified_tab(client, demo_files)
    base = {"damping": "0.7", "saturation": "10", "level": "5", "duration": "3"}
    first = client.post(f"/tab/{tab}/design", data=base | {"wn": "4"})  # draws the mode map once
    assert first.status_code == 200
    wall, cpu, plots, kps = [], [], set(), []
    for wn in np.linspace(3.0, 12.0, 12):
        res = client.post(f"/tab/{tab}/design", data=base | {"wn": f"{wn:.3f}"})
        assert res.status_code == 200
        timing = dict(re.findall(r"(\w+);dur=([\d.]+)", res.headers["server-timing"]))
        wall.append(float(timing["update"]))
        cpu.append(float(timing["cpu"]))
        plots.add(re.search(r'id="closed-loop-plot" alt="[^"]*" src="([^"]+)"', res.text).group(1))
        kps.append(float(re.search(r'data-kp="([^"]+)"', res.text).group(1)))
    assert len(plots) == 12  # every slider position draws its own response
    # Kp of the map's loop grows as ωn² (s² + 2ζωn s + ωn² on the 2nd-order plant)
    sent = np.array([float(f"{wn:.3f}") for wn in np.linspace(3.0, 12.0, 12)])
    np.testing.assert_allclose(np.array(kps) / sent**2, kps[0] / sent[0] ** 2, rtol=1e-5)  # data-kp: 6 digits
    # every update reports its CPU and wall time (the bench reads them)
    assert all(c > 0 for c in cpu) and all(w > 0 for w in wall)


def test_the_design_panel_shows_the_plausible_motors(client, demo_files):
    import base64
    import urllib.parse

    def plot_svg(text):
        src = re.search(r'id="closed-loop-plot"[^>]* src="([^"]+)"', text).group(1)
        head, data = src.split(",", 1)
        return base64.b64decode(data).decode() if head.endswith("base64") else urllib.parse.unquote(data)

    def robust_check(text):
        # the move shows a placeholder that asks for the check with the move's own fields
        line = re.search(r'<p id="robust-line"[^>]*hx-post="([^"]+)"[^>]*hx-trigger="load"[^>]*'
                         r"hx-vals='([^']+)'", text)
        assert line, "no robust placeholder in the move's answer"
        fields = json.loads(html.unescape(line.group(2)))
        res = client.post(line.group(1), data=fields)
        assert res.status_code == 200
        return res.text

    tab = _identified_tab(client, demo_files)
    form = {"damping": "1", "wn": "8", "level": "5", "duration": "3"}
    res = client.post(f"/tab/{tab}/design", data=form)
    assert res.status_code == 200
    assert "margins: gain margin" in res.text
    assert "plausible motors" not in plot_svg(res.text)  # the move itself: no check, no band
    checked = robust_check(res.text)
    assert re.search(r"robust: stable for [\d.]+ % of 100 plausible motors", checked)
    svg = plot_svg(checked)  # the figure comes back with the band, in place of the move's
    assert 'hx-swap-oob="outerHTML"' in checked
    assert "plausible motors 2.5 %" in svg and "plausible motors 97.5 %" in svg
    # the same numbers as the library's own check of the same design on 100 motors
    with client.app.state.tabs.get(tab).lock:
        model = client.app.state.tabs.get(tab).fit.model
    ref = mi.design(model, damping=1.0, wn=8.0, robust_samples=100).robust
    assert f"robust: {html.escape(ref.text())}" in checked
    # the design download carries the check once it is in
    design = json.loads(client.get(f"/tab/{tab}/download/design.json").text)
    assert design.get("robust") is not None
    # with rails the band (a linear loop's) is not drawn, and the figure is not sent again
    res = client.post(f"/tab/{tab}/design", data=form | {"saturation": "2"})
    assert "plausible motors" not in plot_svg(res.text)
    checked = robust_check(res.text)
    assert "robust: stable for" in checked and "closed-loop-plot" not in checked


def test_the_robustness_check_redraws_the_moves_own_run(demo_fit, monkeypatch):
    # the check does not change the controller, so the move's run is the run to redraw with the
    # band: the page passes it instead of simulating again
    from motorid.web.views import DesignForm, design_update, robust_update

    form = DesignForm.from_fields({"damping": "1", "wn": "8", "level": "5", "duration": "3"})
    move = design_update(demo_fit.model, form, None)
    fresh = robust_update(demo_fit.model, form)
    np.testing.assert_array_equal(fresh.design.K, move.design.K)  # the same controller, the same run
    assert fresh.plot is not None

    def no_second_run(*args, **kwargs):
        raise AssertionError("the shown run was simulated again")

    monkeypatch.setattr(mi, "simulate", no_second_run)
    reused = robust_update(demo_fit.model, form, shown=move.simulation)
    assert reused.plot is not None and reused.design.robust is not None
    with pytest.raises(AssertionError, match="simulated again"):  # without it, the check runs it
        robust_update(demo_fit.model, form)


def test_tab_close_deletes_its_folder_and_session(client, demo_files, web_root):
    tab = _identified_tab(client, demo_files)
    folder = next(web_root.iterdir()) / f"tab-{tab}"
    assert any(folder.rglob("*.CSV"))
    assert client.post(f"/tab/{tab}/close").status_code == 204
    assert not folder.exists()
    res = client.post(f"/tab/{tab}/design", data={"damping": "0.7", "wn": "5"})
    assert res.status_code == 422
    assert res.text.count("\n") == 0 and "reload the page" in res.text


def test_server_stop_deletes_every_upload(make_client, demo_files, web_root):
    c = make_client()
    tab = open_tab(c)
    c.post(f"/tab/{tab}/upload", files=multipart("files", demo_files[:2]))
    assert any(web_root.rglob("*.CSV"))
    c.__exit__(None, None, None)
    assert list(web_root.iterdir()) == []


def test_page_errors_are_the_cli_line_in_the_error_box(client, demo_files):
    tab = open_tab(client)
    res = client.get(f"/tab/{tab}/download/model.json")
    assert res.status_code == 422
    assert res.headers["hx-retarget"] == "#errors"
    assert re.fullmatch(r'<p class="error">motorid: error: identify a model first[^\n<]*</p>', res.text)
    client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files))
    # two captures given the same role: refused before any work, naming both
    form = {f"role_{k}": v for k, v in ROLES.items()} | {"role_c1": "position"}
    res = client.post(f"/tab/{tab}/identify", data=form)
    assert res.status_code == 422 and "two captures have the role position" in res.text
    res = client.post(f"/tab/{tab}/identify", data={f"role_{k}": v for k, v in ROLES.items()} | {"order": "7"})
    assert res.status_code == 422 and "order" in res.text


def test_numbers_on_the_page_are_written_as_in_the_terminal(client, demo_files):
    """No ``-0`` step time, a double pole once, the margins of the design — as the CLI prints them."""
    from motorid.numfmt import roots_text

    pages: list[str] = []
    tab = _identified_tab(client, demo_files, pages)
    cells = re.findall(r"<td>(-?[0-9][^<]*)</td>", pages[0])
    assert cells and "-0" not in cells
    res = client.post(f"/tab/{tab}/design", data={"damping": "1", "wn": "6", "level": "5", "duration": "3"})
    assert res.status_code == 200, res.text
    des = client.get(f"/tab/{tab}/download/design.json").json()
    poles = [complex(re_, im) for re_, im in des["closed_loop_poles"]]
    assert f"closed-loop poles: {roots_text(sorted(poles, key=lambda p: (p.real, p.imag)))}" in res.text
    assert "(double)" in res.text and "± 0.000j" not in res.text
    assert "margins: gain margin" in res.text and "phase margin" in res.text


def test_the_model_panel_says_how_to_record_the_next_capture(client, demo_files, demo_fit):
    pages: list[str] = []
    _identified_tab(client, demo_files, pages)
    # the same line as the front door's advice on the same files (the demo records at 1 s/div)
    want = mi.advise(demo_fit).summary_line()
    assert '<p id="advice">' in pages[0]
    assert want in html.unescape(pages[0])


def test_test_signals_in_the_validation_role_carry_no_step_warning(client, demo_files):
    from motorid.conditioning.inspect import describe_capture
    from motorid.io import read_capture

    # the library does warn about the sine's missing step (it is what identify needs) …
    sine = read_capture([f for f in demo_files if f.parent.name == "ALL0003"])
    assert any("open-loop step" in w for w in describe_capture(sine).warnings)
    # … the page, where the sine sits in the validation role, does not
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files))
    assert res.status_code == 200
    row = re.search(r'<tr id="row-c3">(.*?)</tr>', res.text, flags=re.S).group(1)
    assert 'value="validation" selected' in row and "open-loop step" not in row


def test_identify_on_captures_without_a_step_explains_itself_as_the_command_line(client, demo_files):
    tab = open_tab(client)
    sines = [f for f in demo_files if f.parent.name == "ALL0003"]
    assert client.post(f"/tab/{tab}/upload", files=multipart("files", sines)).status_code == 200
    res = client.post(f"/tab/{tab}/identify", data={"role_c0": "validation", "method": "auto"})
    assert res.status_code == 422
    assert "no step in the input channel: identify needs an open-loop step" in res.text
    assert "motorid validate" in res.text


def test_every_action_of_the_page_shows_a_busy_line(client, demo_files):
    """Each request the page can send names a busy indicator that is on the page (or is one).

    An action may take longer than 300 ms on a loaded machine (reading, identifying, a slider
    move with its mode map, the check on the plausible motors, the report): none leaves the page
    looking idle.  The browser test sees the lines appear; this checks every one is wired.
    """
    pages: list[str] = [client.get("/").text]
    tab = re.search(r'data-tab="([0-9a-f]{32})"', pages[0]).group(1)
    pages.append(client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files)).text)
    form = {f"role_{k}": v for k, v in ROLES.items()} | {"method": "auto", "order": "auto", "delay": "auto"}
    pages.append(client.post(f"/tab/{tab}/identify", data=form).text)
    pages.append(client.post(f"/tab/{tab}/design", data={"damping": "0.7", "wn": "5", "saturation": ""}).text)
    page = "\n".join(pages)
    actions = re.findall(r"<[a-z]+\b[^>]*\bhx-(?:post|get)=[^>]*>", page)
    assert len(actions) >= 5  # upload, identify, clear, design, the plausible motors' check
    for tag in actions:
        indicator = re.search(r'hx-indicator="#([\w-]+)"', tag)
        if indicator is None:  # the element is its own busy line (shown while its request runs)
            assert re.search(r'class="[^"]*\bbusy\b', tag), f"no busy indicator: {tag}"
            continue
        target = re.search(rf'<[a-z]+\b[^>]*\bid="{indicator.group(1)}"[^>]*>', page)
        assert target, f"{tag}: indicator #{indicator.group(1)} is not on the page"
        assert "htmx-indicator" in target.group(0) and "busy" in target.group(0)
    # the report (seconds of work) is a plain download: it shows its busy line through data-busy
    assert re.search(r'<a id="dl-report"[^>]*data-busy="[^"]+"', page)


def test_the_page_identifies_one_step_of_a_staircase_log(client, tmp_path):
    """The page's form has the segment field the front door reads: a staircase dropped on the page
    was refused ("no step in the input channel") with no field to pick a step."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("staircase", tmp_path / "stair", seed=0)
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", [rec.files["log"]]))
    assert res.status_code == 200 and 'name="segment"' in res.text
    whole = client.post(f"/tab/{tab}/identify", data={"role_c0": "velocity"})
    assert whole.status_code == 422 and "4 input steps found" in whole.text and "segment N" in whole.text
    res = client.post(f"/tab/{tab}/identify", data={"role_c0": "velocity", "segment": "2"})
    assert res.status_code == 200, res.text
    want = mi.identify(mi.read_experiment(velocity=rec.files["log"], segment=2)).model.to_json()
    got = client.get(f"/tab/{tab}/download/model.json").json()
    assert got["first_order"]["dc_gain"] == pytest.approx(want["first_order"]["dc_gain"], rel=1e-9)


def test_the_closed_loop_table_gives_the_data_units_and_says_when_a_time_was_not_reached(client, tmp_path):
    """On an rpm log the steady-state error is in rpm and the peak command in V (both were labelled V
    whatever the data); a record too short for the response to settle says so, not "nan s"."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("l298n-rpm", tmp_path / "rig", seed=0)
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", [rec.files["log"]]))
    assert res.status_code == 200, res.text
    res = client.post(f"/tab/{tab}/identify", data={"role_c0": "velocity"})
    assert res.status_code == 200, res.text
    # 20 ms of a loop whose poles are at 2 rad/s: neither 90 % of the rise nor the 2 % band is reached
    res = client.post(f"/tab/{tab}/design", data={"damping": "1", "wn": "2", "integral": "on", "level": "100",
                                                     "duration": "0.02"})
    assert res.status_code == 200, res.text
    table = res.text[res.text.index('<table id="metrics">'):]
    table = table[: table.index("</table>")]
    assert "not within the record" in table and "nan" not in table
    row = re.search(r"steady-state error</td><td>([^<]*)</td>", table)
    assert row is not None and row.group(1).endswith(" rpm"), table
    row = re.search(r"peak \|u\|</td><td>([^<]*)</td>", table)
    assert row is not None and row.group(1).endswith(" V"), table


def test_the_page_fits_a_counted_speed_when_its_box_is_ticked(client, tmp_path):
    """The captures form's "speed counted per line" box: the page's model is the front door's
    ``read_experiment(..., counted_velocity=True)`` one (its dead time half an interval shorter)."""
    import motorid as mi
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("l298n-rpm", tmp_path / "rig", seed=0)
    tab = open_tab(client)
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", [rec.files["log"]]))
    assert 'name="counted_velocity"' in res.text
    res = client.post(f"/tab/{tab}/identify", data={"role_c0": "velocity", "counted_velocity": "true"})
    assert res.status_code == 200, res.text
    model = client.get(f"/tab/{tab}/download/model.json").json()
    want = mi.identify(mi.read_experiment(velocity=rec.files["log"], counted_velocity=True)).model
    assert model["timing"]["velocity"]["window_s"] == pytest.approx(0.01)
    assert model["delay_s"] == pytest.approx(want.delay_s, rel=1e-9)


def test_the_design_panel_downloads_its_controller_as_code(client, demo_files, demo_fit):
    """The panel's controller, sampled at its control interval with its rails, as ``design --emit`` writes it;
    the panel's closed loop runs at that interval too (the loop the code will close)."""
    from motorid.control.emit import discretise_design, emit

    tab = _identified_tab(client, demo_files)
    form = {"damping": "0.8", "wn": "6", "integral": "on", "saturation": "5", "level": "2", "duration": "3",
            "dt": "0.002"}
    res = client.post(f"/tab/{tab}/design", data=form)
    assert res.status_code == 200, res.text
    assert "controller code, every 0.002 s, rails ±5 V" in html.unescape(res.text)
    des = mi.design(demo_fit.model, damping=0.8, wn=6.0, integral=True)
    sim = mi.simulate(demo_fit.model, des, duration_s=3.0, level_v=2.0, saturation=5.0, dt_s=0.002)
    shown = re.search(r"overshoot</td><td>([^ ]+) %", res.text).group(1)
    assert float(shown) == pytest.approx(sim.metrics.overshoot_pct, rel=1e-2, abs=1e-3)
    dc = discretise_design(demo_fit.model, des, 0.002, rails=5.0)
    for name, language in (("controller.c", "c"), ("controller.py", "python"), ("controller.m", "matlab")):
        got = client.get(f"/tab/{tab}/download/{name}")
        assert got.status_code == 200 and f'filename="motorid-{name}"' in got.headers["content-disposition"]
        want = emit(dc, language, source="From: elsewhere")
        # the same equations, the header's source line aside
        assert [ln for ln in got.text.splitlines() if "From:" not in ln] == \
            [ln for ln in want.splitlines() if "From:" not in ln]
    code = client.get(f"/tab/{tab}/download/controller.c").text
    assert "#define MOTOR_CONTROLLER_TS 0.002" in code and "#define MOTOR_CONTROLLER_RAILS 5" in code
