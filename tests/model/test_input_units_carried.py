"""A command logged as a PWM duty (counts of 255) through every output: no command labelled V.

The trainer's ``arduino-pwm`` preset writes ``t_ms,pwm,rpm`` as an Arduino sketch does
(``analogWrite`` duty 0 → 153 of a 12 V supply).  Before, the simulation's saturation and
limit-cycle warnings, the design's dead-zone line, the report's mode-map gains and the web page's
rails field said "V" for a command in counts, and the report and the page started from rails of
±10 — ten counts of duty, so the report's closed loop never reached its reference.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from clihelpers import motorid_ok

from motorid.model import MotorModel
from motorid.trainer.realsetups import write_real_setup

#: A number followed by a V label (a command in volts).
VOLTS = re.compile(r"[0-9.]+ V\b")


def _visible(html: str) -> str:
    html = re.sub(r"<(script|style)\b.*?</\1>", "", html, flags=re.S)
    html = re.sub(r'src="data:[^"]*"', "", html)
    return " ".join(re.sub(r"<[^>]+>", " ", html).split())


@pytest.fixture(scope="module")
def rig(tmp_path_factory) -> tuple[Path, Path, object]:
    folder = tmp_path_factory.mktemp("pwm")
    rec = write_real_setup("arduino-pwm", folder / "rig", seed=0)
    model_file = folder / "m.json"
    motorid_ok("identify", *rec.cli_args, "--json", model_file)
    return folder, model_file, rec


def test_the_rig_logs_a_duty_in_counts(rig):
    _, model_file, rec = rig
    lines = rec.files["log"].read_text().splitlines()
    assert lines[0] == "t_ms,pwm,rpm"
    assert {row.split(",")[1] for row in lines[1:]} == {"0", "153"}
    model = json.loads(model_file.read_text())
    assert model["units"] == {"velocity": "rpm", "input": "pwm"} and model["dc_gain_unit"] == "rpm/pwm"
    assert model["first_order"]["dc_gain"] == pytest.approx(rec.truth.dc_gain, rel=0.01)


def test_simulate_and_design_give_the_command_in_pwm(rig):
    folder, model_file, _ = rig
    designed = motorid_ok("design", model_file, "--damping", "1", "--wn", "30", "--integral", "--json",
                          folder / "d.json", "--force").out
    assert "pwm per (rpm·s)" in designed and not VOLTS.search(designed)
    code = motorid_ok("design", model_file, "--damping", "1", "--wn", "30", "--discrete", "0.001", "--saturation",
                      "255", "--emit", "c").out
    assert "u [pwm]" in code and "analogWrite(PWM_PIN, (int)fabs(u));  digitalWrite(DIR_PIN, u >= 0.0);" in code
    tight = motorid_ok("simulate", model_file, folder / "d.json", "--saturation", "10").out
    assert re.search(r"the actuator saturated \(\|u\| reached [0-9.]+ pwm > 10 pwm\)", tight)
    assert not VOLTS.search(tight)


def test_the_report_and_the_page_start_from_rails_the_rig_can_reach(rig):
    folder, model_file, _ = rig
    from motorid.simulation.reference import default_rails

    model = MotorModel.from_json(json.loads(model_file.read_text()))
    assert default_rails(model) == 230.0  # 1.5 × the 153-count step, two digits
    motorid_ok("report", "--velocity", rig[2].files["log"], "--design", folder / "d.json", "--out", folder / "r.html",
               "--force")
    page = _visible((folder / "r.html").read_text())
    assert "the actuator rails ±230 pwm" in page
    assert re.search(r"steady-state error 0 rpm", page)  # the reference is reached (±10 counts never did)
    pytest.importorskip("jinja2", reason="the web extra is not installed")
    from motorid.web.views import slider_ranges

    ranges = slider_ranges(model)
    assert (ranges.input_unit, ranges.rails) == ("pwm", 230.0)


def test_the_mode_maps_gains_carry_the_commands_unit():
    from motorid.report.html import gain_units

    units = gain_units({"position": "deg", "input": "pwm"})
    assert units["kp_unit"] == "pwm/deg" and units["kv_unit"] == "pwm/(deg/s)"
    assert units["units_sentence"].endswith("the input in pwm)")
    assert gain_units({"position": "deg"})["kp_unit"] == "V/deg"  # a command in volts, as logged
