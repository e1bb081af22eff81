"""A log in rpm through every output: no value in rpm is printed or written with a V label.

The trainer's ``l298n-rpm`` preset writes the log as that rig does (``time,voltage,rpm`` at
100 Hz); each front end and each output is run as a user runs it, and its text is searched for
the labels that used to be guessed (``V/V``, ``(volts)``, ``per V of the tacho``, an error "V").
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest
from clihelpers import motorid_ok

from motorid.trainer.realsetups import write_real_setup

#: Labels that would put volts on a value in rpm.
V_ON_RPM = (r"V/V", r"\(volts\)", r"per V of the tacho", r"velocity σ [0-9.e+-]+ V\b", r"dc gain \(V", r"error [-0-9.e+]+ V\b",
            r"offset estimated: [-+0-9.e]+ V\b")


def _cli(*args: object) -> str:
    res = motorid_ok(*args)
    return res.out + res.err


def _no_volts_on_rpm(where: str, text: str) -> None:
    for pattern in V_ON_RPM:
        hit = re.search(pattern, text)
        assert hit is None, f"{where}: {hit.group(0)!r} in …{text[max(0, hit.start() - 80):hit.end() + 40]}…"


def _visible(html: str) -> str:
    html = re.sub(r"<(script|style)\b.*?</\1>", "", html, flags=re.S)
    html = re.sub(r'src="data:[^"]*"', "", html)
    return re.sub(r"<[^>]+>", " ", html)


@pytest.fixture(scope="module")
def rig(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("rpm")
    write_real_setup("l298n-rpm", folder / "rig", seed=0)
    return folder


def test_identify_prints_and_writes_rpm(rig):
    log = rig / "rig" / "l298n_log.csv"
    printed = _cli("identify", "--velocity", log, "--json", rig / "m.json", "--matlab", rig / "m.m",
                   "--report", rig / "r.html", "--force")
    _no_volts_on_rpm("identify printout", printed)
    assert "dc gain (rpm/V)" in printed and "velocity σ" in printed and re.search(r"velocity σ \S+ rpm", printed)
    # the stages' gains carry it too ("stage … dc gain 245.6, τ 0.29 s" had none)
    assert re.search(r"stage .*dc gain [-0-9.e+]+ rpm/V", printed) and not re.search(r"dc gain [-0-9.e+]+[,;]", printed)
    # the Markov method's Laguerre gain too ("DC gain from them 180.7 ± 0.24 (95 %)")
    markov = " ".join(_cli("identify", "--velocity", log, "--method", "markov").split())
    assert re.search(r"DC gain from them [-0-9.e+]+ ± [-0-9.e+]+ rpm/V \(95 %\)", markov)
    model = json.loads((rig / "m.json").read_text())
    assert model["dc_gain_unit"] == "rpm/V" and model["units"]["velocity"] == "rpm"
    script = (rig / "m.m").read_text()
    _no_volts_on_rpm("MATLAB script", script)
    assert "velocity (rpm)" in script
    report = _visible((rig / "r.html").read_text())
    _no_volts_on_rpm("report", report)
    assert "rpm/V" in report
    # the parameter table gives each row its unit (it had none)
    assert re.search(r"<td class=l>dc gain</td><td>[^<]+</td><td>[^<]+</td><td>\[[^<]+\]</td><td>rpm/V</td>",
                     (rig / "r.html").read_text())



def test_the_reports_validation_gives_the_offset_in_rpm(rig):
    """The report's validation table and notes gave the offset of an rpm log in V."""
    log = rig / "rig" / "l298n_log.csv"
    _cli("report", "--velocity", log, "--validate", log, "--out", rig / "rv.html", "--force")
    html = (rig / "rv.html").read_text()
    _no_volts_on_rpm("report's validation", re.sub(r'src="data:[^"]*"', "", html))
    assert re.search(r"<td>[-+0-9.e]+ rpm</td>", html) and re.search(r"offset estimated: [-+0-9.e]+ rpm", html)

def test_validate_design_and_simulate_speak_rpm(rig):
    if not (rig / "m.json").exists():
        _cli("identify", "--velocity", rig / "rig" / "l298n_log.csv", "--json", rig / "m.json", "--force")
    validated = _cli("validate", rig / "m.json", rig / "rig" / "l298n_log.csv")
    _no_volts_on_rpm("validate", validated)
    assert re.search(r"-?[0-9.]+ rpm", validated)  # the offset
    designed = _cli("design", rig / "m.json", "--poles", "-30", "--json", rig / "d.json", "--force")
    _no_volts_on_rpm("design", designed)
    assert "per rpm of the tacho" in designed
    assert re.search(r"kr = [0-9.e+-]+ V per rpm of the reference", designed)  # it had no unit
    integral = _cli("design", rig / "m.json", "--damping", "1", "--wn", "20", "--integral")
    assert re.search(r"ki = [0-9.e+-]+ V per \(rpm·s\) of the integrated error", integral)
    doc = json.loads((rig / "d.json").read_text())
    assert doc["units"]["velocity"] == "rpm"
    assert [g["unit"] for g in doc["gains"]] == ["per rpm of the tacho"]
    simulated = _cli("simulate", rig / "m.json", rig / "d.json", "--level", "100", "--json", rig / "s.json",
                     "--force")
    _no_volts_on_rpm("simulate", simulated)
    assert re.search(r"steady-state error \S+ rpm", simulated) and "peak |u|" in simulated
    assert json.loads((rig / "s.json").read_text())["output_unit"] == "rpm"



def test_the_sweep_table_says_what_its_k_is_in(rig):
    """The paper's sensitivity table gave k = 1474 with no unit; on a log in rpm it is (rpm/V)/s."""
    swept = " ".join(_cli("sweep", "--velocity", rig / "rig" / "l298n_log.csv").split())
    _no_volts_on_rpm("sweep", swept)
    assert "k in (rpm/V)/s" in swept and "τ (s)" in swept

def test_python_and_the_web_page_give_each_parameter_its_unit(rig):
    import motorid as mi

    fit = mi.identify(mi.read_experiment(velocity=rig / "rig" / "l298n_log.csv"))
    assert fit.params["dc_gain"].unit == "rpm/V"
    assert fit.params["time_constant"].unit == "s" and fit.params["pole_1"].unit == "1/s"
    pytest.importorskip("jinja2", reason="the web extra is not installed")
    from motorid.web.views import model_view

    rows = {name: unit for name, _v, _s, _ci, unit in model_view(fit)["params"]}
    assert rows["dc_gain"] == "rpm/V" and rows["delay"] == "s"


def test_a_sensor_constant_on_a_log_already_in_rpm_is_refused_not_dropped(rig):
    import motorid as mi

    with pytest.raises(mi.MotorIdError, match="already in rpm"):
        mi.read_experiment(velocity=rig / "rig" / "l298n_log.csv", scale={"velocity": "0.1V/rpm"})


@pytest.mark.slow
def test_a_batch_never_puts_rpm_and_volts_in_one_distribution(rig, demo_run):
    root = rig / "class"
    (root / "rpm-rig").mkdir(parents=True)
    (root / "rpm-rig" / "l298n_log.csv").write_bytes((rig / "rig" / "l298n_log.csv").read_bytes())
    for name in ("alice", "bob", "carol"):
        (root / name).mkdir()
        (root / name / "ALL0001").symlink_to(demo_run.folder / "ALL0001", target_is_directory=True)
    _cli("batch", root, "--out", rig / "out", "--jobs", "1")
    rows = {r["experiment"]: r for r in csv.DictReader((rig / "out" / "summary.csv").open())}
    assert rows["rpm-rig"]["dc_gain_unit"] == "rpm/V" and rows["alice"]["dc_gain_unit"] == "V/V"
    # scored among its own unit: alone, it is no outlier of the V/V class (z would be ~10⁴ against it)
    assert "gain" not in rows["rpm-rig"]["outlier"] and abs(float(rows["rpm-rig"]["gain_z"])) < 1
    page = (rig / "out" / "summary.html").read_text()
    assert page.count('alt="class distribution"') == 2  # one figure per unit
    assert re.search(r"median DC gain \S+ V/V .*; DC gain \S+ rpm/V|median DC gain \S+ rpm/V", _visible(page))


def test_a_unit_is_a_unit(rig):
    import motorid as mi
    from motorid.model.units import check_unit

    for unit in ("rpm", "rad/s", "V/(rad/s)", "counts", "deg", "m/s^2", "mA", "µA", "rev/min"):
        assert check_unit(unit, "--units", "velocity") == unit
    for bad in ("<script>alert(1)</script>", "rpm; rm -rf /", "two words", "javascript:x"):
        with pytest.raises(mi.MotorIdError, match="not a unit"):
            check_unit(bad, "--units", "velocity")
    with pytest.raises(mi.MotorIdError, match="not a unit"):
        mi.read_experiment(velocity=rig / "rig" / "l298n_log.csv", units={"velocity": "<b>rpm</b>"})
