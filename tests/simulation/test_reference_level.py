"""The reference's level when none is given: 5 on scope volts, the identification step's on other units.

Before, every front end stepped the reference to 5 in the output's unit: on a log in rpm that
was a 5 rpm set-point for a motor the identification drove to 1 100 rpm.  The default is checked
against python-control's DC gain of the model (an independent computation), through the CLI in
a fresh process, the Python front door, the web page's form and the report's caption.
"""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest
from clihelpers import motorid_fresh, motorid_ok

import motorid as mi
from motorid.model import MotorModel
from motorid.simulation.reference import REPORT_LEVEL_V, ReferenceSignal, default_reference_level, with_level
from motorid.trainer import run_experiment
from motorid.trainer.realsetups import write_real_setup


def _two_digits(x: float) -> float:
    return float(f"{x:.2g}")


def _velocity_gain(model: MotorModel) -> float:
    """K of the velocity by python-control, from the model's own state space.

    The velocity's row of ``C``, or for a position alone the position row times ``A`` (the
    position's derivative: its row has no direct term on ``u``).
    """
    outputs = list(model.outputs)
    c = (model.C[outputs.index("velocity")] if "velocity" in outputs
         else model.C[outputs.index("position")] @ model.A)
    # evaluated at s = 1e-6 rad/s, not dcgain(): a position model's A is singular (its
    # integrator), which the velocity row cancels but dcgain's solve does not see (1e-7 relative)
    return float(np.real(control.ss(model.A, model.B, c.reshape(1, -1), 0.0)(1e-6)))


@pytest.fixture(scope="module")
def rigs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("levels")
    out = {}
    for name in ("l298n-rpm", "encoder-counts"):
        rec = write_real_setup(name, folder / name, seed=0)
        model_file = folder / f"{name}.json"
        motorid_ok("identify", *rec.cli_args, "--json", model_file)
        out[name] = model_file
    return out


def test_a_model_in_volts_keeps_the_lab_reports_five_volts():
    rec = run_experiment("paper", seed=0, validation=False)
    model = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="pinv").model
    assert not model.units  # scope volts
    level = default_reference_level(model, "position")
    assert (level.value, level.unit) == (REPORT_LEVEL_V, "V") and "lab report" in level.source
    ref, given = with_level(model, "position", ReferenceSignal(level_v=3.0))
    assert ref.level_v == 3.0 and given.given and given.source == "given"


def test_an_rpm_velocity_loop_steps_to_the_speed_the_identification_reached(rigs):
    model = MotorModel.from_json(json.loads(rigs["l298n-rpm"].read_text()))
    assert model.units.get("velocity") == "rpm" and model.step_volts
    truth = abs(_velocity_gain(model) * model.step_volts)  # python-control: the speed the step settles at
    level = default_reference_level(model, "velocity")
    assert level.unit == "rpm" and level.value == _two_digits(truth)
    assert 500 < level.value < 5000  # a set-point of this motor, not 5 rpm
    des = mi.design(model, poles=[-20.0])
    sim = mi.simulate(model, des, duration_s=1.0)
    assert sim.reference_level == level
    assert float(np.max(sim.reference_v)) == pytest.approx(level.value)
    assert float(sim.output_v[-1]) == pytest.approx(level.value, rel=0.02)  # the loop reaches it
    # a level given is used as given, and said to be given
    sim5 = mi.simulate(model, des, duration_s=1.0, level_v=5.0)
    assert float(np.max(sim5.reference_v)) == 5.0 and sim5.reference_level is not None
    assert sim5.reference_level.given


def test_a_position_loop_in_counts_steps_by_one_time_constant_of_travel(rigs):
    model = MotorModel.from_json(json.loads(rigs["encoder-counts"].read_text()))
    assert model.units.get("position") == "counts" and model.step_volts
    fo = model.first_order()
    truth = abs(_velocity_gain(model) * model.step_volts) * (fo.time_constant_s + model.delay_s)
    level = default_reference_level(model, "position")
    assert level.unit == "counts" and level.value == _two_digits(truth) and level.value > 100


def test_the_cli_prints_and_writes_the_level_and_its_source(rigs, tmp_path):
    model_file = rigs["l298n-rpm"]
    motorid_ok("design", model_file, "--poles", "-20", "--json", tmp_path / "d.json")
    out = motorid_fresh("simulate", model_file, tmp_path / "d.json", "--json", tmp_path / "s.json", cwd=tmp_path)
    model = MotorModel.from_json(json.loads(model_file.read_text()))
    value = default_reference_level(model, "velocity").value
    assert f"reference level {value:.6g} rpm (about the speed the identification's" in out.stdout
    sim = json.loads((tmp_path / "s.json").read_text())
    assert sim["reference_level"]["value"] == value and sim["reference_level"]["unit"] == "rpm"
    assert max(sim["series"]["reference"]) == value
    from jsonschema import validate

    from motorid.schemas import schema

    validate(sim, schema("simulation"))
    given = motorid_ok("simulate", model_file, tmp_path / "d.json", "--level", "700").out
    assert "reference level 700 rpm\n" in given


def test_the_web_form_and_the_report_use_the_same_level(rigs, tmp_path):
    from motorid.web.views import DesignForm, design_update, slider_ranges

    model = MotorModel.from_json(json.loads(rigs["l298n-rpm"].read_text()))
    ranges = slider_ranges(model)
    assert ranges.reference == default_reference_level(model, "velocity")
    form = DesignForm.from_fields({"damping": "1", "wn": "8", "integral": "on", "level": "", "duration": "2"})
    assert form.level_v is None
    view = design_update(model, form, None)
    assert view.simulation.reference_level == ranges.reference
    assert float(np.max(view.simulation.reference_v)) == ranges.reference.value
    from motorid.report.html import _reference_words

    words = _reference_words(ranges.reference.to_dict())
    assert words.startswith(f"The reference steps to {ranges.reference.value:.4g} rpm (about the speed")


def test_a_waves_amplitude_follows_its_level(rigs):
    """The report's 5 + 2 sin ωt on scope volts (amplitude 2 as before); 0.4 × the level elsewhere (it was 2 rpm)."""
    rec = run_experiment("paper", seed=0, validation=False)
    volts = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="pinv").model
    ref, level = with_level(volts, "position", ReferenceSignal(kind="sine"))
    assert (ref.level_v, ref.amplitude_v, level.amplitude) == (5.0, 2.0, 2.0)
    model = MotorModel.from_json(json.loads(rigs["l298n-rpm"].read_text()))
    sim = mi.simulate(model, mi.design(model, poles=[-20.0]), duration_s=8.0, reference="sine")
    level = default_reference_level(model, "velocity").value
    assert sim.reference_level is not None and sim.reference_level.amplitude == pytest.approx(0.4 * level)
    assert float(np.max(sim.reference_v)) == pytest.approx(1.4 * level, rel=1e-6)
    assert float(np.min(sim.reference_v)) == pytest.approx(0.6 * level, rel=1e-6)


def test_a_wave_prints_no_step_metrics(rigs, tmp_path):
    model_file = rigs["l298n-rpm"]
    motorid_ok("design", model_file, "--poles", "-20", "--json", tmp_path / "d.json")
    out = motorid_ok("simulate", model_file, tmp_path / "d.json", "--reference", "sine", "--duration", "8").out
    assert "nan" not in out and "overshoot" not in out and "tracking error (RMS)" in out
    assert "a wave of amplitude" in out.splitlines()[0]
