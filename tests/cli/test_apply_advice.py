"""``motorid acquire --apply-advice``: the advice's settings are sent over SCPI and the files carry them."""

from __future__ import annotations

import json

import pytest
from clihelpers import motorid_ok, run_motorid

from motorid.io import read_capture
from motorid.io.acquire.setup import ScopeSetup, apply_setup, read_advice_setup

pytest.importorskip("pyvisa_sim")  # fallback only: the test command installs the visa extra


def _advice(path, **combined):
    settings = {"volts_per_div": {"input": 5.0, "velocity": 1.0}, "time_per_div_s": 0.25,
                "trigger_position_pct": 20.0, "sample_interval_s": 0.001, "step_volts": 4.0, "averages": 4}
    settings.update(combined)
    path.write_text(json.dumps({"schema": "motorid.advice/1", "now": {}, "suggestions": [],
                                "combined": {"settings": settings, "predicted": {}}}))
    return path


def test_the_scpi_commands_of_a_setup():
    setup = ScopeSetup(volts_per_div={1: 5.0, 2: 0.5}, time_per_div_s=0.25, trigger_position_pct=20.0, averages=64)
    # TDS1000/2000 Programmer Manual: the position is the trigger's time to the screen's centre
    assert setup.commands() == ("HORizontal:MAIn:SCAle 0.25", "HORizontal:MAIn:POSition 0.75", "CH1:SCAle 5",
                                "CH2:SCAle 0.5", "ACQuire:MODe AVErage", "ACQuire:NUMAVg 64")
    assert ScopeSetup(averages=1).commands() == ("ACQuire:MODe SAMple",)

    class Recorder:
        def __init__(self):
            self.sent = []

        def write(self, message):
            self.sent.append(message)

    inst = Recorder()
    assert apply_setup(inst, setup) == tuple(inst.sent)


def test_reading_an_advice_maps_roles_to_channels(tmp_path):
    setup, _ = read_advice_setup(_advice(tmp_path / "a.json"), {1: "input", 2: "velocity"})
    assert setup.volts_per_div == {1: 5.0, 2: 1.0} and setup.averages == 4


def test_acquire_simulate_apply_advice_writes_the_advised_settings(tmp_path):
    advice = _advice(tmp_path / "advice.json")
    res = motorid_ok("acquire", "--simulate", "--apply-advice", advice, "--out", tmp_path / "ALL0000")
    assert "CH2:SCAle 1" in res.out and "ACQuire:NUMAVg 4" in res.out and "warning" not in res.out
    cap = read_capture([tmp_path / "ALL0000" / "F0000CH1.CSV", tmp_path / "ALL0000" / "F0000CH2.CSV"])
    assert cap.output_info.vertical_scale == 1.0
    assert cap.input_info.vertical_scale == 5.0
    assert cap.scope.horizontal_scale_s == 0.25
    assert cap.scope.trigger_index == 500  # 20 % of 2500 points before the trigger
    # the record is the trainer's at those settings: a 4 V step on CH1's 5 V/div grid, 1 ms samples
    assert float(cap.time_s[1] - cap.time_s[0]) == pytest.approx(1e-3)
    assert cap.input_v.max() == pytest.approx(4.0, abs=0.2)


def test_advise_then_acquire_end_to_end(tmp_path):
    # a first capture as the simulated scope holds it (the paper's 1 s/div) → the advice → the scope set to
    # its combined settings
    first = motorid_ok("acquire", "--simulate", "--out", tmp_path / "first")
    assert "saved" in first.out
    advice = tmp_path / "advice.json"
    res = run_motorid("advise", "--velocity", tmp_path / "first" / "ALL0000", "--json")
    assert res.code == 0, res.err
    advice.write_text(res.out)
    combined = json.loads(res.out)["combined"]["settings"]
    motorid_ok("acquire", "--simulate", "--apply-advice", advice, "--out", tmp_path / "second")
    cap = read_capture(tmp_path / "second" / "ALL0000")
    assert cap.scope.horizontal_scale_s == combined["time_per_div_s"]
    assert cap.output_info.vertical_scale == combined["volts_per_div"]["velocity"]


def test_an_advice_for_a_channel_not_acquired_is_one_line(tmp_path):
    advice = _advice(tmp_path / "advice.json", volts_per_div={"input": 2.0, "current": 1.0, "velocity": 2.0})
    res = run_motorid("acquire", "--simulate", "--apply-advice", advice, "--out", tmp_path / "ALL0000")
    assert res.code == 2 and "current" in res.err and "Traceback" not in res.err
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    res = run_motorid("acquire", "--simulate", "--apply-advice", bad, "--out", tmp_path / "ALL0001")
    assert res.code == 2 and "advice" in res.err
