"""Property tests of the model and design JSON loaders.

Valid JSON written by ``model from-params`` / ``design`` is mutated — keys dropped or renamed,
values replaced by wrong types, NaN/±inf/huge numbers, wrong shapes, deep nesting — and must
either load or raise :class:`~motorid.errors.MotorIdError`, never another exception.  The
same holds for the command line's file loaders (``load_model``, the design loader).
"""

from __future__ import annotations

import copy
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motorid.control.design_io import load_design as _load_design
from motorid.model.serialize import load_model
from motorid.control.design import Design, DesignSettings, design_controller
from motorid.control.params import MotorParams, model_from_params
from motorid.errors import MotorIdError
from motorid.model import MotorModel

MODEL = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
MODEL_JSON = json.loads(MODEL.to_json_text())
DESIGN_JSON = json.loads(design_controller(MODEL, DesignSettings(damping=1.0, k2=8.5)).to_json_text())
DESIGN_OBS_JSON = json.loads(design_controller(
    MODEL, DesignSettings(poles=(-3.0, -4.0), observer_poles=(-30.0, -40.0))).to_json_text())

FLOATS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e308, -1e308, 1e-308, float("nan"), float("inf"), -float("inf")]),
    st.integers(min_value=-(2**70), max_value=2**70),
)
SCALARS = st.one_of(st.none(), st.booleans(), FLOATS, st.text(max_size=8))
JUNK = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                    st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                    max_leaves=12)


def _paths(doc, prefix=()):
    """Every (container, key) location in a JSON document."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _get_parent(doc, path):
    for k in path[:-1]:
        doc = doc[k]
    return doc


@st.composite
def mutated(draw, valid):
    """A copy of ``valid`` with 1-4 random mutations."""
    doc = copy.deepcopy(valid)
    for _ in range(draw(st.integers(1, 4))):
        paths = list(_paths(doc))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _get_parent(doc, path), path[-1]
        kind = draw(st.sampled_from(["drop", "rename", "junk", "wrap", "unwrap", "float", "deep", "shape"]))
        if kind == "drop":
            del parent[key]
        elif kind == "rename" and isinstance(parent, dict):
            parent[key + draw(st.sampled_from(["_", "X", " "]))] = parent.pop(key)
        elif kind == "junk":
            parent[key] = draw(JUNK)
        elif kind == "wrap":
            parent[key] = [parent[key]]
        elif kind == "unwrap" and isinstance(parent[key], list) and parent[key]:
            parent[key] = parent[key][0]
        elif kind == "float":
            parent[key] = draw(FLOATS)
        elif kind == "deep":
            v = parent[key]
            for _ in range(draw(st.integers(2, 60))):
                v = [v]
            parent[key] = v
        elif kind == "shape" and isinstance(parent[key], list):
            parent[key] = parent[key] + parent[key][:1] if draw(st.booleans()) else parent[key][:-1]
    return doc


def _loads_or_refuses(fn, data) -> None:
    try:
        fn(data)
    except MotorIdError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg.strip(), msg
    # anything else propagates and fails the test


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(MODEL_JSON))
def test_model_from_json_mutated(doc):
    _loads_or_refuses(lambda d: MotorModel.from_json(d, file="m.json"), doc)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mutated(DESIGN_JSON), mutated(DESIGN_OBS_JSON)))
def test_design_from_json_mutated(doc):
    _loads_or_refuses(lambda d: Design.from_json(d, file="d.json"), doc)


@settings(max_examples=100, deadline=None)
@given(JUNK)
def test_loaders_on_arbitrary_json(doc):
    _loads_or_refuses(lambda d: MotorModel.from_json(d, file="m.json"), doc)
    _loads_or_refuses(lambda d: Design.from_json(d, file="d.json"), doc)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=mutated(MODEL_JSON))
def test_cli_loaders_from_files(tmp_path, doc):
    """The files as the command line reads them (bare NaN/Infinity as Python's json writes them)."""
    p = tmp_path / "m.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    _loads_or_refuses(lambda _: load_model(p), None)
    _loads_or_refuses(lambda _: _load_design(p), None)


@pytest.mark.parametrize("text", [
    "[" * 100_000 + "]" * 100_000,
    '{"schema": "motorid.model/1", "state_space": ' + "[" * 50_000 + "]" * 50_000 + "}",
    "",
    "null",
    "\ufeff{}",
    '{"schema": "motorid.model/1"}',
    '{"schema": "motorid.design/1"}',
    "NaN",
    "1e999",
])
def test_cli_loaders_on_hostile_files(tmp_path, text):
    p = tmp_path / "x.json"
    p.write_text(text, encoding="utf-8")
    _loads_or_refuses(lambda _: load_model(p), None)
    _loads_or_refuses(lambda _: _load_design(p), None)


def test_valid_documents_load():
    """The unmutated documents load (the properties above are not vacuous)."""
    m = MotorModel.from_json(MODEL_JSON, file="m.json")
    assert m.order == MODEL.order
    assert Design.from_json(DESIGN_JSON, file="d.json").K.shape == (2,)
    assert Design.from_json(DESIGN_OBS_JSON, file="d.json").L is not None
