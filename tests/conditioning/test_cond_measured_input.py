"""A log's input column that measured the drive's voltage is timed as a scope's, not as a command.

A PicoScope's CSV export is a plain CSV, and every plain CSV's input was taken for a command a
loop logged: the step at the stamp of its first sample at the new level.  A scope (or an ADC, a
DAQ) samples a voltage whose step fell somewhere in the interval before that sample.  On the
picoscope rig preset the residence time came out up to 1.45 % short, its interval (±0.3 %) missing
the truth in 4 of 6 seeds.  A column that scatters around both of its levels is now such a
measured voltage: the instant is the interval's middle, its ±dt/√12 in the intervals.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from clihelpers import motorid_fresh

from motorid.conditioning.edge import step_edge
from motorid.conditioning.response import measured_input


def _column(kind: str) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    t = np.arange(400) * 1e-3
    u = np.where(np.arange(400) >= 150, 4.0, 0.0)
    if kind == "measured":  # an 8-bit channel: noise quantised to 39 mV codes
        u = np.round((u + rng.normal(0.0, 0.012, u.size)) / 0.039) * 0.039
    elif kind == "two codes":  # a level between two codes: it alternates between them
        u = u + np.where(np.arange(400) % 3 == 0, 0.039, 0.0)
    elif kind == "closed loop":  # a controller's command: no level on either side
        u = u + 0.5 * np.sin(np.arange(400) / 7.0)
    return t, u


@pytest.mark.parametrize(("kind", "measured"), [("command", False), ("measured", True), ("two codes", True),
                                                ("closed loop", False)])
def test_a_measured_voltage_is_told_from_a_command(kind, measured):
    t, u = _column(kind)
    assert measured_input(u, step_edge(t, u)) is measured
    assert measured_input(None, step_edge(t, u)) is False


def test_the_picoscope_log_is_timed_as_a_scope_and_its_interval_covers_the_truth(tmp_path):
    """Seed 0 of the rig (its step 0.64 ms before the first sample at the new level), through the
    command line in a fresh process: before, the residence time was 0.96 % short with an interval of
    ±0.16 %; now the instant is the interval's middle and the interval holds its ±dt/√12."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("picoscope", tmp_path / "rig", seed=0)
    out = tmp_path / "m.json"
    proc = motorid_fresh("identify", *rec.cli_args, "--json", out, cwd=tmp_path)
    model = json.loads(out.read_text())
    assert model["timing"]["velocity"]["kind"] == "sampled"
    lo, hi = model["uncertainty"]["residence_time_s"]["ci95"]
    assert lo <= rec.truth.residence_time_s <= hi, (lo, hi, rec.truth.residence_time_s)
    assert hi - lo > 2 * 1.96 * 1e-3 / np.sqrt(12) * 0.9  # the instant's ±dt/√12 is in it (dt 1 ms)
    assert "a measured voltage rather than a logged command" in " ".join(proc.stdout.split())


def test_inspect_says_where_the_step_instant_is_taken(tmp_path, run_cli):
    """``motorid inspect``: the picoscope log's step instant is sampled, the l298n log's is logged (the
    same words in the table, the same key in the JSON, which keeps to its schema)."""
    import jsonschema

    from motorid.schemas import schema
    from motorid.trainer.realsetups import write_real_setup

    pico = write_real_setup("picoscope", tmp_path / "p", seed=0)
    rpm = write_real_setup("l298n-rpm", tmp_path / "r", seed=0)
    columns = pico.cli_args[pico.cli_args.index("--columns") + 1]
    res = run_cli("inspect", pico.files["log"], "--columns", columns, "--json")
    assert res.code == 0, res.err
    doc = json.loads(res.out)
    jsonschema.validate(doc, schema("inspect"))
    assert doc[0]["step"]["timing"] == "sampled"
    res = run_cli("inspect", rpm.files["log"], "--json")
    assert json.loads(res.out)[0]["step"]["timing"] == "logged"
    res = run_cli("inspect", rpm.files["log"])
    assert "at its stamp (logged)" in res.out
