"""``motorid scope list`` and ``motorid acquire`` against the simulated TDS 2012C.

The must-show: ``acquire --simulate --out ALL0000 --identify`` saves files that read back to
the trainer's quantised volts, written as the demo writes the same capture, and the model
identified from them is the model ``motorid identify`` gets from the demo's files, close to
the trainer's truth.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("pyvisa_sim")  # fallback only: the test command installs the visa extra

from motorid.io import read_tds_capture, write_tds_capture
from motorid.trainer import run_experiment


def _one_error_line(res, *needles):
    assert res.code == 2, (res.out, res.err)
    lines = res.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motorid: error: "), res.err
    for n in needles:
        assert n in lines[0], lines[0]


def test_scope_list_simulate_lists_the_tds2012(run_cli):
    res = run_cli("scope", "list", "--simulate")
    assert res.code == 0, res.err
    assert "USB0::0x0699::0x03A4::VIRTUAL::0::INSTR" in res.out
    assert "TEKTRONIX,TDS 2012C,VIRTUAL" in res.out
    res = run_cli("scope", "list", "--simulate", "--json")
    assert json.loads(res.out) == [{"resource": "USB0::0x0699::0x03A4::VIRTUAL::0::INSTR",
                                    "idn": "TEKTRONIX,TDS 2012C,VIRTUAL,CF:91.1CT FV:v24.26", "problem": None}]


@pytest.fixture(scope="module")
def trainer_velocity():
    exp = run_experiment("paper", seed=0, roles=("velocity",), validation=False)
    return exp


def test_acquire_simulate_identify_matches_the_file_path_and_the_truth(run_cli, tmp_path, monkeypatch,
                                                                       trainer_velocity):
    monkeypatch.chdir(tmp_path)
    res = run_cli("acquire", "--simulate", "--out", "ALL0000", "--identify", "--json", "acquired.json")
    assert res.code == 0, res.err
    assert "saved: ALL0000" in res.out and "identify: motorid identify --velocity ALL0000" in res.out
    cap = trainer_velocity.captures["velocity"]

    # 1. the saved files read back to the simulated (trainer's quantised) volts
    back = read_tds_capture(tmp_path / "ALL0000")
    lsb = 2.0 / 25  # CH1 and CH2 at 2 V/div
    for got, want in ((back.input_v, cap.input_v), (back.output_v, cap.output_v)):
        assert np.array_equal(np.rint(got / lsb), np.rint(want / lsb))  # every 8-bit level
        assert np.max(np.abs(got - want)) <= 1e-14
    assert np.max(np.abs(back.time_s - cap.time_s)) <= 1e-12
    assert back.scope.trigger_index == cap.scope.trigger_index and back.warnings == ()

    # 2. written as the demo writes the same capture: same bytes, but for the trainer's "-0.00000"
    #    (its quantiser keeps the sign of a rounded-away negative; a code 0 from a scope has none)
    demo = write_tds_capture(tmp_path / "demo", cap, index=0)
    for n in (1, 2):
        ours = (tmp_path / "ALL0000" / f"F0000CH{n}.CSV").read_text()
        theirs = (demo / f"F0000CH{n}.CSV").read_text().replace("  -0.00000,", "   0.00000,")
        assert ours == theirs

    # 3. the model is the one `motorid identify` gets from the demo's files
    res = run_cli("identify", "--velocity", demo, "--json", "from_files.json")
    assert res.code == 0, res.err
    acquired = json.loads((tmp_path / "acquired.json").read_text())
    from_files = json.loads((tmp_path / "from_files.json").read_text())
    for key in ("method", "order", "first_order", "poles", "zeros", "state_space", "uncertainty"):
        assert acquired[key] == from_files[key], key

    # 4. and close to the trainer's truth (independent of our output; tolerances as the tutorial's test):
    #    the gain a step shows (linear × (1 − offset/step)) within 0.5 %, the linear τ in the 95 % interval
    truth = trainer_velocity.truth
    effective = truth.dc_gain * (1 - truth.equivalent_input_offset_v / trainer_velocity.step_volts)
    assert acquired["first_order"]["dc_gain"] == pytest.approx(effective, rel=0.005)
    lo, hi = acquired["uncertainty"]["time_constant"]["ci95"]
    assert lo <= truth.time_constant_s <= hi


def test_acquire_numbers_the_saves_and_refuses_to_overwrite(run_cli, tmp_path):
    for expected in ("ALL0000", "ALL0001"):
        res = run_cli("acquire", "--simulate", "--out", tmp_path, "--sim-role", "current")
        assert res.code == 0, res.err
        assert f"saved: {tmp_path / expected}" in res.out
    before = (tmp_path / "ALL0001" / "F0001CH2.CSV").read_bytes()
    res = run_cli("acquire", "--simulate", "--out", tmp_path / "ALL0001", "--sim-seed", "3")
    _one_error_line(res, "--force", "F0001CH1.CSV")
    assert (tmp_path / "ALL0001" / "F0001CH2.CSV").read_bytes() == before


def test_role_of_ch2_is_guessed_or_given(run_cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # the position capture (encoder wraps) is recognised without --role
    res = run_cli("acquire", "--simulate", "--sim-role", "position", "--out", "ALL0000", "--identify")
    assert res.code == 0, res.err
    assert "identify: motorid identify --position ALL0000" in res.out
    # a CH2-only acquisition identified with the role given and the step level
    res = run_cli("acquire", "--simulate", "--out", "ALL0001", "--channels", "2", "--role", "CH2=velocity",
                  "--identify", "--step-volts", "5.92")
    assert res.code == 0, res.err
    assert "identify: motorid identify --velocity ALL0001/F0001CH2.CSV" in res.out
    assert not (tmp_path / "ALL0001" / "F0001CH1.CSV").exists()


@pytest.mark.parametrize("args, needles", [
    (["--role", "CH3=velocity"], ["CH3 is not acquired", "--channels"]),
    (["--role", "CH2=torque"], ["unknown role 'torque'"]),
    (["--role", "CH1=input", "--role", "CH2=input"], ["two input channels"]),
    (["--channels", "1,5"], ["--channels", "1 to 4"]),
    (["--json", "m.json"], ["--identify"]),
    (["--encoding", "hex"], ["encoding 'hex'"]),
    (["--timeout", "0"], ["timeout must be > 0"]),
    (["--sim-role", "torque"], ["--sim-role 'torque'"]),
])
def test_bad_options_are_one_line_and_write_nothing(run_cli, tmp_path, args, needles):
    res = run_cli("acquire", "--simulate", "--out", tmp_path / "ALL0000", *args)
    _one_error_line(res, *needles)
    assert not (tmp_path / "ALL0000").exists()


def _sim_file(tmp_path, **kw):
    from motorid.trainer.scope_sim import simulated_tds2012

    return simulated_tds2012(tmp_path, **kw)


def test_never_triggers_says_so_with_the_fix(run_cli, tmp_path):
    sim = _sim_file(tmp_path, triggers=False)
    res = run_cli("acquire", "--visa-library", sim.visa_library, "--resource", sim.resource, "--single",
                  "--timeout", "0.3", "--encoding", "ascii", "--out", tmp_path / "ALL0000")
    _one_error_line(res, "did not trigger within --timeout 0.3 s", "trigger")
    assert not (tmp_path / "ALL0000").exists()


def test_channel_off_says_which_and_the_fix(run_cli, tmp_path):
    sim = _sim_file(tmp_path, displayed=(1,))
    res = run_cli("acquire", "--visa-library", sim.visa_library, "--out", tmp_path / "ALL0000")
    _one_error_line(res, "CH2 is switched off", "--channels")


def test_no_backend_and_no_instrument(run_cli, tmp_path):
    res = run_cli("scope", "list", "--visa-library", "@nosuchbackend")
    _one_error_line(res, "no VISA backend", "pyvisa-py")
    empty = tmp_path / "none.yaml"
    empty.write_text('spec: "1.1"\ndevices: {}\nresources: {}\n', encoding="utf-8")
    res = run_cli("scope", "list", "--visa-library", f"{empty}@sim")
    _one_error_line(res, "no instrument found", "switch it on")
    res = run_cli("acquire", "--visa-library", f"{empty}@sim", "--out", tmp_path / "ALL0000")
    _one_error_line(res, "no instrument found")
