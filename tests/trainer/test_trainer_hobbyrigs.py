"""The hobby-rig presets write what those rigs write, with an honest truth.

Checked against the files themselves (independent of any identification): the stamps' clock
(``millis()`` steps of 10 and 11 ms, a host loop's 4–22 ms, whole milliseconds under ``time``),
integer counts, the staircase's levels, and each truth's gain against the steady level the file
shows.  Identification accuracy is ``bench/real_setups.py``'s job.
"""

from __future__ import annotations

import numpy as np
import pytest
from clihelpers import motorid_fresh

from motorid.io import read_capture
from motorid.trainer.hobbyrigs import HOBBY_RIGS, STAIR_LEVELS_V
from motorid.trainer.realsetups import REAL_SETUPS, write_real_setup

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def rigs(tmp_path_factory):
    root = tmp_path_factory.mktemp("rigs")
    return {name: write_real_setup(name, root / name, seed=1) for name in HOBBY_RIGS}


def _table(rec) -> np.ndarray:
    return np.loadtxt(rec.files["log"], delimiter=",", skiprows=1)


def test_every_hobby_rig_is_a_real_setup_and_reads_back(rigs):
    assert set(HOBBY_RIGS) <= set(REAL_SETUPS)
    for rec in rigs.values():
        args = list(rec.cli_args)
        columns = None
        if "--columns" in args:  # the PicoScope's channels are named A and B: the user maps them
            columns = dict(p.split("=", 1) for p in args[args.index("--columns") + 1].split(","))
        cap = read_capture(rec.files["log"], columns=columns)
        assert cap.n_samples >= 250 and np.all(np.isfinite(cap.output_v))


def test_the_new_formats_are_written_as_those_rigs_write_them(rigs):
    """The Serial Plotter's label:value lines with the last cut; PicoScope's units line, blank line
    and 8-bit codes; a Raspberry Pi's wall-clock stamps about 20 ms apart."""
    lines = rigs["serial-plotter"].files["log"].read_text().splitlines()
    assert all(ln.startswith("t:") and ",pwm_V:" in ln and ",rpm:" in ln for ln in lines[:-1])
    assert lines[-1].endswith(",rp")
    pico = rigs["picoscope"].files["log"].read_text().splitlines()
    assert pico[:3] == ["Time,Channel A,Channel B", "(ms),(V),(V)", ""]
    tacho = np.array([float(ln.split(",")[2]) for ln in pico[3:]])
    lsb = 2 * 2.0 / 256
    np.testing.assert_allclose(tacho / lsb, np.round(tacho / lsb), atol=1e-6)
    rows = rigs["clock-stamps"].files["log"].read_text().splitlines()
    assert rows[0] == "timestamp,pwm_volts,rpm"
    stamps = np.array([np.datetime64(r.split(",")[0].replace(" ", "T")) for r in rows[1:]])
    steps = np.diff(stamps).astype("timedelta64[us]").astype(float) / 1e6
    assert 0.019 < float(np.mean(steps)) < 0.021 and np.std(steps) > 5e-4


def test_the_clocks_are_the_rigs_clocks(rigs):
    stamps = _table(rigs["arduino-millis"])[:, 0]
    assert np.all(stamps == np.round(stamps)) and set(np.diff(stamps).astype(int)) == {10, 11}
    host = np.diff(_table(rigs["host-loop"])[:, 0])
    assert host.min() >= 0.004 - 1e-4 and host.max() <= 0.022 + 1e-4 and np.ptp(host) > 0.01
    ms = _table(rigs["ms-time"])[:, 0]
    assert np.all(np.diff(ms) == 10)
    counts = _table(rigs["encoder-counts"])[:, 1]
    assert np.all(counts == np.round(counts))


def test_the_staircase_levels(rigs):
    u = _table(rigs["staircase"])[:, 1]
    assert sorted(set(u.tolist())) == list(STAIR_LEVELS_V)
    assert rigs["staircase"].cli_args[-2:] == ("--segment", "2")


@pytest.mark.parametrize("name, column", [("l298n-rpm", 2), ("arduino-millis", 2), ("ms-time", 2), ("arduino-pwm", 2)])
def test_each_truth_gain_is_the_steady_level_the_file_shows(rigs, name, column):
    rec = rigs[name]
    data = _table(rec)
    final = float(np.mean(data[-60:, column]))  # settled: 10+ time constants after the step
    assert final / rec.truth.step_volts == pytest.approx(rec.truth.dc_gain, rel=0.01)


def test_the_position_rigs_ramp_at_the_truths_speed(rigs):
    for name, column in (("host-loop", 2), ("encoder-counts", 1)):
        rec = rigs[name]
        data = _table(rec)
        t, pos = data[:, 0], data[:, column]
        tail = t > t[-1] - 0.5
        slope = np.polyfit(t[tail], pos[tail], 1)[0]
        assert slope / rec.truth.step_volts == pytest.approx(rec.truth.dc_gain, rel=0.01)


@pytest.mark.parametrize("name", HOBBY_RIGS)
def test_each_rig_through_the_cli_in_a_fresh_process(name, tmp_path):
    """As a user runs it: ``python -m motorid identify <the rig's arguments>`` in a new process with
    the default environment, default options; gain within 1 %, residence time within 5 %."""
    import json

    rec = write_real_setup(name, tmp_path / name, seed=0)
    out = tmp_path / "m.json"
    motorid_fresh("identify", *rec.cli_args, "--json", out, cwd=tmp_path)
    m = json.loads(out.read_text())
    assert m["first_order"]["dc_gain"] == pytest.approx(rec.truth.dc_gain, rel=0.01)
    residence = m["first_order"]["time_constant"] + (m.get("delay_s") or 0.0)
    # a model that fitted the counting (its velocity's window) is the motor's, without the counting's lag
    counted = bool(m.get("timing", {}).get("velocity", {}).get("window_s"))
    assert counted == (name == "clock-stamps")  # read as counted: a count over its own clock's interval
    truth = rec.truth.residence_time_s - (rec.truth.sensor_lag_s if counted else 0.0)
    assert residence == pytest.approx(truth, rel=0.05)
