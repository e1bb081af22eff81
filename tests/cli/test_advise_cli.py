"""``motorid advise`` through the command line: the printout, the advice JSON and its schema, refusals."""

from __future__ import annotations

import json
import subprocess
import sys

import jsonschema
import pytest
from clihelpers import motorid_ok, run_motorid

from motorid.io import write_tds_capture
from motorid.schemas import schema
from motorid.trainer.experiment import run_experiment


def _record(folder, **settings):
    exp = run_experiment("paper", seed=0, roles=("velocity",), validation=False, **settings)
    return write_tds_capture(folder, exp.captures["velocity"], index=1)


@pytest.fixture(scope="module")
def short_record(tmp_path_factory):
    # 100 ms/div, 30 % before the trigger: the record ends at about 1.6 τ
    return _record(tmp_path_factory.mktemp("short"), sec_per_div=0.1, trigger_position_pct=30.0)


def test_advise_json_in_a_fresh_process_matches_its_schema(short_record):
    out = subprocess.run([sys.executable, "-m", "motorid", "advise", "--velocity", str(short_record), "--json"],
                         capture_output=True, text=True, check=True).stdout
    doc = json.loads(out)
    jsonschema.Draft202012Validator(schema("advice")).validate(doc)
    assert doc["suggestions"][0]["setting"] == "time_per_div_s"
    assert doc["combined"]["settings"]["time_per_div_s"] > 0.1
    assert doc["worth_changing"] is True


def test_advise_prints_the_table_and_the_combined_settings(short_record):
    res = motorid_ok("advise", "--velocity", short_record)
    assert "recorded at: velocity 2 V/div" in res.out
    assert "time_per_div_s" in res.out and "all together:" in res.out


def test_a_well_recorded_capture_gets_one_line(tmp_path):
    cap = _record(tmp_path, sec_per_div=0.25, trigger_position_pct=10.0)
    res = motorid_ok("advise", "--velocity", cap)
    assert "advice: nothing worth changing" in res.out


def test_refusals_are_one_line(short_record):
    res = run_motorid("advise", "--velocity", short_record, "--method", "pinv")
    assert res.code == 2 and "auto or oe" in res.err and "Traceback" not in res.err
    res = run_motorid("advise", "--velocity", short_record, "--threshold", "20")
    assert res.code == 2 and "--threshold" in res.err


def test_identify_prints_one_line_of_advice(short_record, tmp_path):
    res = motorid_ok("identify", "--velocity", short_record)
    line = [x for x in res.out.splitlines() if x.startswith("advice:")]
    assert len(line) == 1 and "time/div" in line[0]
    good = motorid_ok("identify", "--velocity", _record(tmp_path, sec_per_div=0.25, trigger_position_pct=10.0))
    assert "advice: nothing worth changing" in good.out
