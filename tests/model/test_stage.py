"""Typed stages: the model's ``stages`` are :class:`Stage` objects whose JSON is
the same object, key for key and in the same order, as the dicts they replaced."""

from __future__ import annotations

import json

import pytest

from motorid.model import MotorModel
from motorid.model.stage import Stage


def test_stages_of_an_auto_identification_are_typed_and_round_trip(demo_run):
    doc = json.loads((demo_run.folder / "model.json").read_text())
    model = MotorModel.from_json(doc)
    assert model.stages and all(isinstance(st, Stage) for st in model.stages)
    # the JSON text is unchanged by the round trip through the typed objects
    assert json.dumps(model.to_json()["stages"]) == json.dumps(doc["stages"])
    paper = [st for st in model.stages if st.name == "paper method"]
    assert paper and all(isinstance(st.dc_gain, float) and st.time_constant_s > 0 for st in paper)
    assert {st.method for st in paper} >= {"pinv", "classic"}
    oe = next(st for st in model.stages if st.name == "output-error")
    assert "structures" in oe.details and oe["initialised_from"] == oe.details["initialised_from"]


def test_stage_is_a_read_only_mapping_with_the_json_keys():
    d = {"stage": "paper method", "method": "pinv", "order": 2, "dc_gain": 0.9, "time_constant": 0.43,
         "velocity_nrmse": 0.01}
    st = Stage.from_dict(d)
    assert st.time_constant_s == 0.43 and st["time_constant"] == 0.43 and st.get("missing") is None
    assert list(st) == list(d) and dict(st) == d
    with pytest.raises(KeyError):
        st["nope"]
    failed = Stage.from_dict({"stage": "srivc (second opinion)", "failed": "no convergence"})
    assert failed.failed == "no convergence" and failed.method is None
    assert failed.to_dict() == {"stage": "srivc (second opinion)", "failed": "no convergence"}
