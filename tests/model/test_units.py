"""units: the gain reads in the data's units (rpm/V for a log in rpm) and per
physical unit when a sensor constant is given; the JSON says its unit."""

from __future__ import annotations

import json
import re

import pytest

from motorid.model.units import ChannelScale, dc_gain_unit, parse_scales, parse_units, physical_gain


def test_hslu_log_in_rpm_prints_the_gain_in_rpm_per_volt(real_dir, run_cli, tmp_path):
    # must-show: `motorid identify` on ../shared/real/hslu-rtl-dcmotor prints the gain in rpm/V
    f = real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv"
    m = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", f, "--json", m)
    assert res.code == 0, res.err
    line = next(ln for ln in res.out.splitlines() if ln.startswith("first order"))
    gain = float(re.search(r"dc gain (\S+) rpm/V", line).group(1))
    doc = json.loads(m.read_text())
    assert doc["dc_gain_unit"] == "rpm/V" and doc["units"]["velocity"] == "rpm"
    # the authors' own first-order fit: ≈ 245.5 rpm/V (../shared/real/README.md)
    assert gain == pytest.approx(245.5, rel=0.01)
    assert gain == pytest.approx(doc["first_order"]["dc_gain"], rel=1e-3)


def test_a_tacho_constant_gives_the_gain_per_rad_s(demo_run, run_cli, tmp_path):
    d = demo_run.folder
    m = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", d / "ALL0001", "--scale", "velocity=0.5V/(rad/s)", "--json", m,
                  "--method", "classic")
    assert res.code == 0, res.err
    doc = json.loads(m.read_text())
    assert doc["dc_gain_unit"] == "V/V"
    assert doc["scales"]["velocity"] == {"volts_per_unit": 0.5, "unit": "rad/s"}
    phys = float(re.search(r"dc gain (\S+) \(rad/s\)/V", res.out).group(1))
    assert phys == pytest.approx(doc["first_order"]["dc_gain"] / 0.5, rel=1e-3)


def test_declared_units_override_and_bad_scales_are_one_line(demo_run, run_cli):
    d = demo_run.folder
    res = run_cli("identify", "--velocity", d / "ALL0001", "--units", "velocity=krpm", "--method", "classic")
    assert res.code == 0 and "krpm/V" in res.out
    res = run_cli("identify", "--velocity", d / "ALL0001", "--scale", "velocity=fast")
    assert res.code == 2 and res.err.count("\n") == 1 and "volts per unit" in res.err
    res = run_cli("identify", "--velocity", d / "ALL0001", "--units", "speed=rpm")
    assert res.code == 2 and "unknown channel 'speed'" in res.err


def test_unit_helpers():
    assert parse_units(["velocity=rpm,current=A"]) == {"velocity": "rpm", "current": "A"}
    sc = parse_scales(["current=0.47ohm", "position=20V/rev"])
    assert sc["current"] == ChannelScale(0.47, "A") and sc["position"] == ChannelScale(20.0, "rev")
    assert dc_gain_unit({}) == "V/V" and dc_gain_unit({"velocity": "rpm"}) == "rpm/V"
    assert physical_gain(0.9, {}, {"velocity": ChannelScale(0.1504, "rad/s")}) == pytest.approx(
        (0.9 / 0.1504, "(rad/s)/V"))
    assert physical_gain(245.0, {"velocity": "rpm"}, {"velocity": ChannelScale(0.1, "rad/s")}) is None


def _pwm_log(path, column: str = "pwm", level: float = 200.0):
    """A 100 Hz log whose command is an Arduino's ``analogWrite`` value (0 → 200), not volts."""
    import numpy as np

    t = np.arange(400) * 0.01
    u = np.where(t >= 1.0, level, 0.0)
    y = np.where(t >= 1.0, 5.4 * level * (1 - np.exp(-np.maximum(t - 1.0, 0) / 0.08)), 0.0)
    y = y + np.random.default_rng(0).normal(0, 1.0, t.size)
    path.write_text(f"time,{column},rpm\n" + "".join(f"{a:.2f},{b:g},{c:.2f}\n" for a, b, c in zip(t, u, y,
                                                                                                  strict=True)))
    return path


def test_a_pwm_command_is_not_labelled_volts_anywhere(tmp_path, run_cli):
    """A log whose command column is ``pwm`` (0–255 counts) printed "step 200 V" and "dc gain
    (rpm/V)", the PID "V per rpm", simulate "peak |u| … V": every one a guessed label.  Now the
    command's unit comes from its column name and travels to each output."""
    log = _pwm_log(tmp_path / "log.csv")
    m = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", log, "--json", m, "--matlab", tmp_path / "m.m")
    assert res.code == 0, res.err
    doc = json.loads(m.read_text())
    assert doc["units"]["input"] == "pwm" and doc["dc_gain_unit"] == "rpm/pwm"
    assert doc["first_order"]["dc_gain"] == pytest.approx(5.4, rel=0.01)
    assert "step 200 pwm" in res.out.splitlines()[0] and "dc gain (rpm/pwm)" in res.out
    assert "(step 200 pwm)" in (tmp_path / "m.m").read_text() and "amplifier volts" not in (tmp_path / "m.m").read_text()
    des = tmp_path / "pid.json"
    res = run_cli("design", m, "--pid", "--json", des)
    assert res.code == 0, res.err
    assert "pwm per rpm" in res.out and "rpm/pwm" in res.out and " V per " not in res.out
    res = run_cli("design", m, "--damping", "1", "--wn", "20", "--integral")
    assert res.code == 0 and "pwm per rpm of the tacho" in res.out
    res = run_cli("simulate", m, des, "--level", "100")
    assert res.code == 0, res.err
    assert re.search(r"peak \|u\| \S+ pwm", res.out) and not re.search(r"peak \|u\| \S+ V\b", res.out)
    # a duty cycle in percent
    res = run_cli("identify", "--velocity", _pwm_log(tmp_path / "duty.csv", "duty_pct", 60.0), "--method", "classic")
    assert res.code == 0 and "rpm/%" in res.out



def test_the_sanity_gate_speaks_the_datas_units(tmp_path, run_cli):
    """The gate's messages said "of the 200 V step" on a PWM log and gave its first-order
    baseline's gain without a unit ("K 1080")."""
    import numpy as np

    log = _pwm_log(tmp_path / "sag.csv")
    rows = log.read_text().splitlines()
    t = np.arange(len(rows) - 1) * 0.01
    # the command sags and recovers after its step (a drive that cannot hold it): not a step
    sag = [f"{a:.2f},{200.0 * (1 - 0.15 * np.sin(3 * (a - 1.0))) if a >= 1.0 else 0.0:g},{r.split(',')[2]}"
           for a, r in zip(t, rows[1:], strict=True)]
    log.write_text(rows[0] + "\n" + "\n".join(sag) + "\n")
    res = run_cli("identify", "--velocity", log, "--json", tmp_path / "m.json")
    text = " ".join((res.out + res.err).split())  # the console wraps long lines where the path puts them
    assert re.search(r"of the [0-9.]+ pwm step", text) and " V step" not in text
    details = " | ".join(c["detail"] for c in json.loads((tmp_path / "m.json").read_text())["extras"]["sanity"]["checks"])
    assert re.search(r"\(K [0-9.e+-]+ rpm/pwm, τ", details) and "per volt" not in details
    assert re.search(r"DC gain [0-9.e+-]+ rpm/pwm; the model's final level per pwm of step", details)
    assert re.search(r"headline DC gain [0-9.e+-]+ rpm/pwm inside its 95 % interval \[.*\] rpm/pwm", details)
    assert re.search(r"headline τ [0-9.e+-]+ s inside", details)


def test_a_simulations_table_gives_the_command_its_unit(tmp_path):
    """``SimulationResult.to_dataframe`` labelled the command "V" on a PWM model."""
    import motorid as mi

    fit = mi.identify(mi.read_experiment(velocity=_pwm_log(tmp_path / "log.csv")))
    sim = mi.simulate(fit.model, mi.design(fit.model, damping=1.0, wn=20.0, integral=True), duration_s=0.5)
    units = sim.to_dataframe().attrs["units"]
    assert units["u"] == "pwm" and units["u_raw"] == "pwm" and units["output"] == "rpm"

@pytest.mark.parametrize(("name", "unit"), [
    ("omega_rad_s", "rad/s"), ("rad_s", "rad/s"), ("speed_deg_per_s", "deg/s"), ("speed_rps", "rev/s"),
    ("vel_m_s", "m/s"), ("time_s", "s"), ("t_s", "s"), ("speed_rpm", "rpm"), ("u_V", "V"), ("pwm", "pwm"),
    ("duty_pct", "%"), ("w [rad/s]", "rad/s"), ("voltage", ""), ("pwm_volts", "V"), ("i_amps", "A"),
])
def test_a_column_name_gives_its_unit_and_a_rate_is_read_whole(name, unit):
    """``omega_rad_s`` (the arduino-millis rig's column) was read as seconds: "dc gain (s/V)"."""
    from motorid.io._table import _units_from_name

    assert _units_from_name(name) == unit


def test_a_rate_gain_unit_is_written_with_parentheses():
    assert dc_gain_unit({"velocity": "rad/s"}) == "(rad/s)/V"
    assert dc_gain_unit({"velocity": "rpm", "input": "pwm"}) == "rpm/pwm"


def test_the_command_unit_can_be_declared(tmp_path, run_cli):
    """A log whose command column says nothing of its unit (``u``) was labelled volts with no way to
    say otherwise: ``--units input=pwm`` was refused ("unknown channel 'input'")."""
    import motorid as mi

    log = _pwm_log(tmp_path / "log.csv", column="u")
    res = run_cli("identify", "--velocity", log, "--units", "input=pwm", "--method", "classic")
    assert res.code == 0, res.err
    assert " rpm/pwm" in res.out and "step 200 pwm" in res.out
    fit = mi.identify(mi.read_experiment(velocity=log, units={"input": "pwm"}), method="classic")
    assert fit.model.dc_gain_unit == "rpm/pwm"
    res = run_cli("identify", "--velocity", log, "--units", "torque=Nm")
    assert res.code == 2 and "use position, velocity, current, input" in res.err


def test_a_position_only_log_gives_its_velocity_gain_per_second_of_its_unit(tmp_path, run_cli):
    """An encoder log in counts (the encoder-counts and host-loop rigs) printed "dc gain (V/V): 6692":
    the gain of the position's derivative, in counts/s per volt, labelled volts per volt."""
    from motorid.model.units import with_velocity_of_position
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("encoder-counts", tmp_path / "enc", seed=0)
    m = tmp_path / "m.json"
    res = run_cli("identify", *rec.cli_args, "--json", m)
    assert res.code == 0, res.err
    doc = json.loads(m.read_text())
    assert doc["units"] == {"position": "counts", "velocity": "counts/s"}
    assert doc["dc_gain_unit"] == "(counts/s)/V" and "dc gain ((counts/s)/V)" in res.out
    assert doc["first_order"]["dc_gain"] == pytest.approx(rec.truth.dc_gain, rel=0.01)
    # a velocity unit given by the user is kept; a scope's potentiometer gives V/s
    assert with_velocity_of_position({"position": "deg", "velocity": "rpm"}, ["position"])["velocity"] == "rpm"
    assert with_velocity_of_position({}, ["position"]) == {"velocity": "V/s"}
    assert with_velocity_of_position({"position": "rad"}, ["position", "velocity"]) == {"position": "rad"}


def test_a_gain_names_the_sensor_the_units_speak_of():
    """An encoder log's gains read "per counts of the potentiometer" and "per deg/s/s"."""
    from motorid.control.coordinates import SENSOR_UNITS, sensor_unit

    assert sensor_unit("position", {"position": "counts"}) == "per counts of the encoder"
    assert sensor_unit("position", {"position": "deg"}) == "per deg of the angle sensor"
    assert sensor_unit("velocity", {"velocity": "counts/s"}) == "per counts/s of the measured velocity"
    assert sensor_unit("acceleration", {"velocity": "deg/s"}) == "per deg/s² of the measured velocity's derivative"
    assert sensor_unit("velocity", {"velocity": "rpm"}) == "per rpm of the tacho"  # a tacho in rpm stays one
    assert SENSOR_UNITS["acceleration"] == "per V/s of the tacho's derivative"  # the scope's words, as before
