"""The control commands (``model from-params``, ``design``, ``simulate``, ``modes``) on a test app.

The commands are registered with :func:`motorid.cli.control.register` on a fresh typer app, as
``motorid.cli.app`` does; user errors surface as MotorIdError (``main()`` maps them to exit 2).
"""

from __future__ import annotations

import json

import pytest
import typer
from typer.testing import CliRunner

from motorid.cli.control import register
from motorid.errors import MotorIdError, OutputExistsError

runner = CliRunner()


def _app() -> typer.Typer:
    app = typer.Typer()

    @app.callback()
    def _root() -> None:
        pass

    register(app)
    return app


APP = _app()
PARAMS = ["model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"]


@pytest.fixture()
def model_file(tmp_path):
    out = tmp_path / "m.json"
    res = runner.invoke(APP, [*PARAMS, "--json", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_from_params_then_design_report_numbers(model_file, tmp_path):
    assert json.loads(model_file.read_text())["schema"] == "motorid.model/1"
    d = tmp_path / "d.json"
    res = runner.invoke(APP, ["design", str(model_file), "--k2", "8.5", "--damping", "1", "--json", str(d)])
    assert res.exit_code == 0, res.output
    assert "k1 = 19.64" in res.output and "kr = 19.64" in res.output
    assert "k2 > -1.111" in res.output and "closed-loop poles: -7.863 (double)" in res.output
    data = json.loads(d.read_text())
    assert data["K"][0] == pytest.approx(19.64, abs=0.01) and data["kr"] == pytest.approx(data["K"][0])


def test_refuses_overwrite_without_force(model_file):
    res = runner.invoke(APP, [*PARAMS, "--json", str(model_file)])
    assert isinstance(res.exception, OutputExistsError)
    assert runner.invoke(APP, [*PARAMS, "--json", str(model_file), "--force"]).exit_code == 0


def test_step_test_variant(tmp_path):
    res = runner.invoke(APP, ["model", "from-step-test", "--v-tacho-ss", "9", "--u-step", "10", "--Tm", "0.55",
                              "--delta-theta", "15", "--delta-t", "0.867", "--gear", "1/36"])
    assert res.exit_code == 0, res.output
    assert "k0 = 0.25" in res.output


@pytest.mark.parametrize("args,msg", [
    (["--poles=-1,-2,-3"], "exactly 2"),
    (["--poles=-1+2j,-3"], "conjugate"),
    (["--k2", "8.5", "--damping", "1", "--observer-poles=5,-3"], "left half-plane"),
    (["--k2", "8.5", "--damping", "1", "--observer-poles=-50,-40", "--output", "velocity"], "not observable"),
])
def test_bad_design_input_is_one_line(model_file, args, msg):
    res = runner.invoke(APP, ["design", str(model_file), *args])
    assert isinstance(res.exception, MotorIdError), res.output
    assert msg in str(res.exception) and "\n" not in str(res.exception)
    assert str(model_file) in str(res.exception)


def test_wrong_schema_model(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema": "motorid.design/1"}))
    res = runner.invoke(APP, ["design", str(bad), "--poles=-1,-2"])
    assert isinstance(res.exception, MotorIdError) and "schema" in str(res.exception)
    junk = tmp_path / "junk.json"
    junk.write_text("{not json")
    res = runner.invoke(APP, ["design", str(junk), "--poles=-1,-2"])
    assert isinstance(res.exception, MotorIdError)


def test_gear_must_be_a_number(tmp_path):
    res = runner.invoke(APP, ["model", "from-params", "--km", "1", "--kT", "1", "--gear", "1/0", "--k0", "1",
                              "--Tm", "1"])
    assert isinstance(res.exception, MotorIdError) and "--gear" in str(res.exception)


def test_simulate_and_modes(model_file, tmp_path):
    d = tmp_path / "d.json"
    assert runner.invoke(APP, ["design", str(model_file), "--k2", "8.5", "--damping", "1", "--json", str(d)]).exit_code == 0
    png, csv = tmp_path / "s.png", tmp_path / "s.csv"
    res = runner.invoke(APP, ["simulate", str(model_file), str(d), "--x0", "2,0", "--duration", "2",
                              "--saturation", "10", "--png", str(png), "--csv", str(csv)])
    assert res.exit_code == 0, res.output
    assert "settling time" in res.output and png.exists() and csv.exists()
    mpng, mjson = tmp_path / "m.png", tmp_path / "modes.json"
    res = runner.invoke(APP, ["modes", str(model_file), "--kp", "0:600:20", "--kv", "0:40:20", "--png", str(mpng),
                              "--json", str(mjson)])
    assert res.exit_code == 0, res.output
    data = json.loads(mjson.read_text())
    assert len(data["modes"]) == 20 and "criteria" in data
    assert mpng.read_bytes()[:4] == b"\x89PNG"
    res = runner.invoke(APP, ["modes", str(model_file), "--kp", "0:1", "--kv", "0:40:20"])
    assert isinstance(res.exception, MotorIdError)


def test_simulate_says_its_controller_is_sampled_and_how_often(model_file, tmp_path):
    """The design's numbers are the continuous loop's; simulate runs a digital controller (the
    command held for --dt). On the encoder rig's model, designed for 5 % overshoot, simulate
    printed 5.156 % at the default 1 ms with nothing saying why it was not 5 %."""
    d = tmp_path / "d.json"
    assert runner.invoke(APP, ["design", str(model_file), "--settling-time", "1", "--overshoot", "5", "--json",
                               str(d)]).exit_code == 0
    over = {}
    for dt in ("0.01", "0.0001"):
        res = runner.invoke(APP, ["simulate", str(model_file), str(d), "--dt", dt, "--json", str(tmp_path / f"{dt}.json")])
        assert res.exit_code == 0, res.output
        assert f"the controller runs every {dt} s (--dt), its command held between samples" in res.output
        over[dt] = json.loads((tmp_path / f"{dt}.json").read_text())["metrics"]["overshoot_pct"]
    assert over["0.01"] > over["0.0001"]  # the slower the sampling, the less damped the loop
