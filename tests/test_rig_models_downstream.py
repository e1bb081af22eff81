"""The models identified from each rig the trainer records go on through the whole path:
design, simulate and the report, from Python and from the command line (the model as
identified, not a hand-made one)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from clihelpers import motorid_ok

import motorid as mi
from motorid.trainer.realsetups import write_real_setup

pytestmark = pytest.mark.slow

RIGS = ("l298n-rpm", "arduino-millis", "host-loop", "encoder-counts", "ms-time", "fast-tbs1000", "no-header")


def _poles(model) -> list[float]:
    # one real pole per state, a little faster than the model's slowest
    slow = float(np.min(np.abs(model.poles()[np.abs(model.poles()) > 1e-9]))) if model.order else 1.0
    return [-slow * (1.5 + 0.5 * k) for k in range(model.order)]


@pytest.mark.parametrize(("rig", "counted", "method"), [(rig, False, "auto") for rig in RIGS]
                         + [("l298n-rpm", True, "auto"), ("ms-time", True, "auto"),
                            # a count over five lines kept for five, modelled (timing.velocity.count_hold)
                            ("pwm-encoder", True, "auto"),
                            # the Markov method's model of a log without an input (its onset's shift, no dead
                            # time) and of an rpm log in whole counts
                            ("encoder-counts", False, "markov"), ("l298n-rpm", False, "markov")])
def test_each_rig_model_through_design_simulate_and_report(rig, counted, method, tmp_path):
    rec = write_real_setup(rig, tmp_path / rig, seed=0)
    # a speed counted per line is fitted as the motor's model: the same path downstream
    args = [*rec.cli_args, *(["--counted-velocity"] if counted else []), "--method", method]
    motorid_ok("identify", *args, "--json", tmp_path / "m.json", "--report", tmp_path / "r.html")
    doc = json.loads((tmp_path / "m.json").read_text())
    assert ("window_s" in doc.get("timing", {}).get("velocity", {})) == counted
    assert doc.get("timing", {}).get("velocity", {}).get("count_hold", 1) == (5 if counted and rig == "pwm-encoder"
                                                                              else 1)
    model = mi.MotorModel.from_json(doc)
    # Python: the model the CLI wrote
    des = mi.design(model, poles=_poles(model))
    sim = mi.simulate(model, des, duration_s=2.0, level_v=1.0)
    assert np.all(np.isfinite(sim.output_v)) and sim.output_unit == (model.units.get(des.output) or "V")
    # the command line: the same model, a design, a simulation and a report with both
    motorid_ok("design", tmp_path / "m.json", "--poles", ",".join(f"{p:g}" for p in _poles(model)),
               "--json", tmp_path / "d.json")
    motorid_ok("simulate", tmp_path / "m.json", tmp_path / "d.json", "--duration", "2", "--json", tmp_path / "s.json")
    assert json.loads((tmp_path / "s.json").read_text())["output_unit"] == sim.output_unit
    assert (tmp_path / "r.html").stat().st_size > 10_000
    # the report says why the intervals are wider than the noise makes them, as the printout does: a step
    # instant read off the response (the encoder log and the scope's tacho and current: no input channel) holds
    # a lag under half a sample
    report = (tmp_path / "r.html").read_text()
    onset = "the step instant is read off the response (no input channel)" in report
    assert onset == bool(doc["uncertainty"].get("onset_lag_s")) == (rig in ("encoder-counts", "fast-tbs1000")), rig
    # a speed that comes in whole counts, fitted as samples, may count over each line: its intervals reach lower
    counts = "the speed comes in whole counts" in report
    may_count = rig in ("l298n-rpm", "arduino-millis", "ms-time", "no-header") and not counted
    assert counts == bool(doc["uncertainty"].get("counting_lag_s")) == may_count, rig
    # the report with that design: its closed loop simulated on the identified model
    motorid_ok("identify", *args, "--report", tmp_path / "r2.html", "--design", tmp_path / "d.json")
    page = (tmp_path / "r2.html").read_text()
    assert "no controller design given" not in page and "cannot be simulated" not in page
