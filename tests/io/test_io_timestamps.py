"""Time stamps as real rigs write them: jittered clocks, millisecond columns, headers that disagree.

Each log is written in the test from a known plant (python-control): a 2-pole motor with a 30 ms
dead time, 200 rpm/V, stepped by 6 V; its mean residence time is 0.15 + 0.02 + 0.03 = 0.2 s.
"""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest

from motorid.errors import MotorIdError
from motorid.io import read_capture

DC, RESIDENCE = 200.0, 0.2
_G = control.tf([DC], np.polymul([0.15, 1], [0.02, 1]))
_FT = np.arange(0, 5, 1e-4)
_FY = np.ravel(control.step_response(_G, _FT).outputs)


def _speed(t: np.ndarray, t_step: float, rng: np.random.Generator) -> np.ndarray:
    te = t - t_step - 0.03
    return np.where(te >= 0, 6.0 * np.interp(te, _FT, _FY), 0.0) + rng.normal(0, 2.0, t.size)


def _write(path: Path, header: str, stamps: list[str], t: np.ndarray, k_step: int, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    u = np.where(np.arange(t.size) >= k_step, 6.0, 0.0)
    y = _speed(t, t[k_step], rng)
    path.write_text(header + "\n" + "\n".join(f"{a},{b:.2f},{c:.2f}" for a, b, c in zip(stamps, u, y, strict=True)))
    return path


def millis_log(path: Path) -> Path:
    """An Arduino loop of 10.24 ms stamped with ``millis()``: steps of 10 and 11 ms."""
    stamps = np.floor(np.arange(300) * 10.24 + 1234).astype(int)
    return _write(path, "millis,pwm_volts,speed_rpm", [str(s) for s in stamps], stamps / 1e3, 60)


def _identify(run_cli, f: Path, tmp_path: Path, *extra: str) -> tuple[dict, str]:
    out = tmp_path / (f.stem + ".json")
    res = run_cli("identify", "--velocity", str(f), "--json", str(out), *extra)
    assert res.code == 0, res.err
    return json.loads(out.read_text()), res.out + res.err


def test_millis_stamps_are_resampled_and_identified_right(tmp_path, run_cli):
    """Before: refused, "time step 0.011 s differs from the sample interval 0.01 s (gap or corrupt
    record)".  After: resampled with a note giving the jitter; gain and residence time right."""
    f = millis_log(tmp_path / "millis.csv")
    cap = read_capture(f)
    assert np.ptp(np.diff(cap.time_s)) < 1e-9 and np.mean(np.diff(cap.time_s)) == pytest.approx(0.01024, rel=1e-3)
    model, text = _identify(run_cli, f, tmp_path)
    assert "time stamps jitter" in text and "10–11 ms" in text
    assert model["first_order"]["dc_gain"] == pytest.approx(DC, rel=0.01)
    assert model["first_order"]["residence_time_s"] == pytest.approx(RESIDENCE, rel=0.05)


def test_host_loop_stamps_of_4_to_22_ms(tmp_path, run_cli):
    rng = np.random.default_rng(3)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.004, 0.022, 299))] + 5.0
    k = int(np.searchsorted(t, 5.6))
    f = _write(tmp_path / "ev3.csv", "time_s,power,speed_rpm", [f"{x:.6f}" for x in t], t, k)
    model, text = _identify(run_cli, f, tmp_path)
    assert "time stamps jitter" in text
    assert model["first_order"]["dc_gain"] == pytest.approx(DC, rel=0.01)
    assert model["first_order"]["residence_time_s"] == pytest.approx(RESIDENCE, rel=0.05)


def test_a_gap_and_time_going_back_are_still_refused_naming_the_row(tmp_path):
    t = np.arange(300) * 0.01
    gap = t + np.where(np.arange(300) >= 150, 0.5, 0.0)  # 50 samples lost at row 150
    f = _write(tmp_path / "gap.csv", "time_s,voltage,speed", [f"{x:.3f}" for x in gap], gap, 60)
    with pytest.raises(MotorIdError, match=r"gap\.csv:152: .*gap or corrupt record"):
        read_capture(f)
    back = t.copy()
    back[200] = 1.5
    f = _write(tmp_path / "back.csv", "time_s,voltage,speed", [f"{x:.3f}" for x in back], t, 60)
    with pytest.raises(MotorIdError, match=r"back\.csv:202: .*goes backwards"):
        read_capture(f)


def test_a_plain_time_column_of_milliseconds(tmp_path, run_cli):
    """Before: integer ms under ``time`` read as seconds (τ = 152 s, "all sanity checks passed").
    After: read as milliseconds with a note; ``--time-unit`` overrides either way."""
    stamps = 1000 + 10 * np.arange(300)
    f = _write(tmp_path / "ms.csv", "time,voltage,speed", [str(s) for s in stamps], stamps / 1e3, 60)
    cap = read_capture(f)
    assert np.median(np.diff(cap.time_s)) == pytest.approx(0.01)
    assert any("read as milliseconds" in w and "--time-unit s" in w for w in cap.warnings)
    model, _ = _identify(run_cli, f, tmp_path)
    assert model["first_order"]["residence_time_s"] == pytest.approx(RESIDENCE, rel=0.05)
    assert np.median(np.diff(read_capture(f, columns={"time_unit": "s"}).time_s)) == pytest.approx(10.0)
    res = run_cli("inspect", str(f), "--time-unit", "ms")
    assert res.code == 0 and "read as milliseconds" not in res.out + res.err


@pytest.mark.parametrize("header, scale", [("t_ms", 1e-3), ("time [ms]", 1e-3), ("time (us)", 1e-6),
                                           ("t [µs]", 1e-6), ("micros", 1e-6), ("time_s", 1.0)])
def test_the_unit_in_the_column_name(tmp_path, header, scale):
    stamps = np.arange(300) * (10 if scale == 1e-3 else 10_000 if scale == 1e-6 else 0.01)
    f = _write(tmp_path / "n.csv", f"{header},voltage,speed", [f"{s:g}" for s in stamps], stamps * scale, 60)
    assert np.median(np.diff(read_capture(f).time_s)) == pytest.approx(0.01)


def test_an_ambiguous_whole_number_column_is_refused_naming_the_option(tmp_path):
    stamps = 500 * np.arange(300)  # 500 ms or 500 µs?
    f = _write(tmp_path / "amb.csv", "time,voltage,speed", [str(s) for s in stamps], stamps * 1e-6, 60)
    with pytest.raises(MotorIdError, match="--time-unit ms or --time-unit us"):
        read_capture(f)
    assert np.median(np.diff(read_capture(f, columns={"time_unit": "us"}).time_s)) == pytest.approx(5e-4)


def test_a_tektronix_header_that_contradicts_its_time_column(tmp_path, run_cli):
    """``Sample Interval 2e-3`` over a time column stepping 4e-3: the warning names both and says
    which one is used, in the printout and the model JSON."""
    from motorid.io import write_tds_capture
    from motorid.trainer import run_experiment

    exp = run_experiment("paper", seed=1, validation=False, roles=("velocity",))
    folder = write_tds_capture(tmp_path, exp.captures["velocity"], index=0)
    ch2 = Path(folder) / "F0000CH2.CSV"
    text = ch2.read_text()
    assert "Sample Interval,4.000000e-03" in text
    ch2.write_text(text.replace("Sample Interval,4.000000e-03", "Sample Interval,2.000000e-03"))
    model, _ = _identify(run_cli, Path(folder), tmp_path)
    assert any("Sample Interval 0.002 s differs from the time column's step 0.004 s; the time column is used" in w
               for w in model["warnings"])


def test_the_clock_resolution_of_jittered_stamps_is_read_off_them(tmp_path):
    """``millis()`` rounds each instant down to whole ms: the logged step instant is off by up to
    1 ms against the samples, which the timing intervals must carry (before: taken as exact, the
    arduino-millis rig's residence-time interval missed the truth in 6 seeds of 6, by up to 28 σ)."""
    from motorid.io._common import stamp_resolution

    assert read_capture(millis_log(tmp_path / "millis.csv")).stamp_resolution_s == pytest.approx(1e-3)
    rng = np.random.default_rng(3)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.004, 0.022, 299))] + 5.0
    k = int(np.searchsorted(t, 5.6))
    # a host loop stamped to the µs by time.time(): exact enough; printed to 0.1 ms: that resolution
    fine = _write(tmp_path / "us.csv", "time_s,power,speed_rpm", [f"{x:.6f}" for x in t], t, k)
    coarse = _write(tmp_path / "tenth.csv", "time_s,power,speed_rpm", [f"{x:.4f}" for x in t], t, k)
    assert read_capture(fine).stamp_resolution_s == 0.0
    assert read_capture(coarse).stamp_resolution_s == pytest.approx(1e-4)
    # uniform stamps are taken as exact (a loop that keeps its period), however they are printed
    uniform = np.arange(300) * 0.01
    f = _write(tmp_path / "uniform.csv", "time_s,voltage,speed", [f"{x:.2f}" for x in uniform], uniform, 60)
    assert read_capture(f).stamp_resolution_s == 0.0
    assert stamp_resolution(np.array([0.010, 0.011, 0.010])) == pytest.approx(1e-3)
    assert stamp_resolution(np.array([0.0102, 0.0104])) == pytest.approx(2e-4)
    assert stamp_resolution(np.array([0.01, np.nan])) == 0.0
