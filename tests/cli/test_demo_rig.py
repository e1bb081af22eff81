"""``motorid demo --rig NAME``: a step recorded as a real rig logs it, identified as a user would.

Before, the rig presets could be recorded from Python only (``write_real_setup``); a student or an
instructor had no command for them.  The identification goes through the front door with the
rig's own arguments; the printout puts the identified gain and residence time, with their
intervals, beside the trainer's truth.
"""

from __future__ import annotations

import json

import pytest

from motorid.cli.demo import read_options_of
from motorid.options import TRAINER_RIGS
from motorid.trainer.realsetups import REAL_SETUPS


@pytest.mark.parametrize("rig", ["staircase", "picoscope", "fast-tbs1000"])
def test_a_rig_demo_writes_the_rigs_files_and_identifies_them(rig, tmp_path, run_cli, monkeypatch):
    out = tmp_path / "d"
    res = run_cli("demo", "--rig", rig, "--out", str(out), "--seed", "1")
    assert res.code == 0, res.err
    truth = json.loads((out / "truth.json").read_text())
    model = json.loads((out / "model.json").read_text())
    assert truth["schema"] == "motorid.rig-truth/1" and truth["rig"] == rig and truth["seed"] == 1
    assert truth["files"] and all((out / name).is_file() for name in truth["files"].values())
    assert model["first_order"]["dc_gain"] == pytest.approx(truth["dc_gain"], rel=0.01)
    assert model["first_order"]["residence_time_s"] == pytest.approx(truth["residence_time_s"], rel=0.05)
    assert "identify it yourself: motorid identify " in res.out
    assert "identified from the log vs the trainer's truth" in res.out
    # the command a user types in that folder gives the same model
    monkeypatch.chdir(out)
    assert run_cli("identify", *truth["identify_args"], "--json", str(tmp_path / "again.json")).code == 0
    again = json.loads((tmp_path / "again.json").read_text())
    assert again["first_order"] == model["first_order"]


def test_the_rig_names_are_declared_once_and_checked(tmp_path, run_cli):
    assert REAL_SETUPS == TRAINER_RIGS
    res = run_cli("demo", "--rig", "nosuch", "--out", str(tmp_path / "x"))
    assert res.code == 2 and "l298n-rpm" in res.err and len(res.err.strip().splitlines()) == 1
    res = run_cli("demo", "--rig", "l298n-rpm", "--preset", "lab-report", "--out", str(tmp_path / "y"))
    assert res.code == 2 and "--preset and --step-volts belong to the scope demo" in res.err
    assert not (tmp_path / "y").exists()


def test_the_rig_arguments_are_read_options():
    assert read_options_of(["--velocity", "a.csv", "--step-volts", "6", "--segment", "2",
                            "--columns", "time=Time,input=Channel A"]) == {
        "velocity": "a.csv", "step_volts": 6.0, "segment": 2, "columns": {"time": "Time", "input": "Channel A"}}


def test_a_position_log_in_degrees_says_what_did_not_run_and_no_volts(tmp_path, run_cli):
    """The EV3 log (position in degrees, no speed column): the SRIVC second opinion did not run and
    says why (it printed its name and nothing else), and the derivative's note names no volts."""
    import numpy as np

    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("host-loop", tmp_path / "ev3", seed=1)
    res = run_cli("identify", *rec.cli_args, "--json", str(tmp_path / "m.json"))
    assert res.code == 0, res.err
    text = " ".join(res.out.split())  # the printout wraps its long lines
    assert "stage srivc (second opinion): did not run: SRIVC needs a velocity capture" in text
    assert "velocity is the derivative of the position (the position's unit per second)" in text
    assert "volts per second" not in text
    model = json.loads((tmp_path / "m.json").read_text())
    assert model["units"]["position"] == "deg" and model["dc_gain_unit"] == "(deg/s)/V"
    assert np.isfinite(model["first_order"]["dc_gain"])


def test_a_column_whose_unit_nothing_gives_is_said_to_be_labelled_volts_by_default(tmp_path, run_cli):
    """The ms-time log's ``speed`` column (rad/s, but its name and the file say nothing): the printout
    labels it V, the default, and now says so and how to give the unit; with ``--units`` the note
    goes and the gain reads (rad/s)/V."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("ms-time", tmp_path / "ms", seed=0)
    res = run_cli("identify", *rec.cli_args)
    assert res.code == 0, res.err
    text = " ".join(res.out.split())
    assert "automatic choice: no unit given for 'speed' (velocity)" in text
    assert "labelled V, the default" in text and "--units velocity=" in text
    res = run_cli("identify", *rec.cli_args, "--units", "velocity=rad/s")
    text = " ".join(res.out.split())
    assert res.code == 0 and "no unit given" not in text
    assert "dc gain ((rad/s)/V)" in text
    # a scope's CSV says its volts: no such note on the demo's captures
    scope = write_real_setup("fast-tbs1000", tmp_path / "tbs", seed=0)
    assert "no unit given" not in " ".join(run_cli("identify", *scope.cli_args).out.split())


def test_srivc_on_a_position_log_says_why_it_found_no_model(tmp_path, run_cli):
    """``--method srivc`` on an encoder log (no velocity column) said "SRIVC found no stable model"
    and hid each structure's refusal: it needs a velocity capture."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("encoder-counts", tmp_path / "mouse", seed=0)
    res = run_cli("identify", *rec.cli_args, "--method", "srivc")
    assert res.code == 2
    assert "SRIVC found no stable model at the requested order(s): SRIVC needs a velocity capture" in res.err
    assert len(res.err.strip().splitlines()) == 1
