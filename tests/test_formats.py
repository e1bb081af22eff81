"""The documents motorid writes match the JSON Schemas it ships, and docs/formats.md names them.

Each document is produced as a user produces it (the CLI on the demo captures) and validated
with ``jsonschema`` (an independent validator) against ``motorid.schemas``; a document that
lost a required key, or a key whose type changed, fails here.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import jsonschema
import pytest
from clihelpers import motorid_ok

from motorid.schemas import SCHEMA_NAMES, schema

REPO = Path(__file__).resolve().parents[1]
FORMATS = REPO / "docs" / "formats.md"


def _valid(name: str, doc: object) -> None:
    validator = jsonschema.Draft202012Validator(schema(name))
    errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.path))
    assert not errors, "\n".join(f"{list(e.path)}: {e.message[:200]}" for e in errors[:5])


@pytest.mark.parametrize("name", SCHEMA_NAMES)
def test_each_shipped_schema_is_a_valid_draft_2020_12_schema(name):
    s = schema(name)
    jsonschema.Draft202012Validator.check_schema(s)
    assert s["$id"].startswith("motorid.")


def test_an_unknown_schema_name_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="model, design"):
        schema("modle")


def test_the_schemas_reject_a_document_that_lost_a_required_key(demo_run):
    doc = json.loads((demo_run.folder / "model.json").read_text())
    _valid("model", doc)
    for key in ("first_order", "poles", "state_space"):
        broken = {k: v for k, v in doc.items() if k != key}
        assert list(jsonschema.Draft202012Validator(schema("model")).iter_errors(broken)), key
    bad = dict(doc, first_order={"dc_gain": "0.9", "time_constant": 0.4})
    assert list(jsonschema.Draft202012Validator(schema("model")).iter_errors(bad))


@pytest.fixture(scope="module")
def documents(demo_run, tmp_path_factory):
    """Every JSON document, written through the CLI from the demo's captures."""
    d, out = demo_run.folder, tmp_path_factory.mktemp("formats")
    runs = {
        "model-pinv": ("identify", "--position", d / "ALL0000", "--velocity", d / "ALL0001",
                       "--method", "pinv", "--json", out / "pinv.json"),
        "model-velocity": ("identify", "--velocity", d / "ALL0001", "--json", out / "velocity.json"),
        "design": ("design", d / "model.json", "--damping", "0.9", "--wn", "5", "--integral", "--ki", "2",
                   "--json", out / "design.json"),
        "simulation": ("simulate", d / "model.json", out / "design.json", "--duration", "1",
                       "--json", out / "sim.json"),
        "modes": ("modes", d / "model.json", "--kp", "0:100:4", "--kv", "0:5:4", "--json", out / "modes.json"),
        "batch": ("batch", out / "root", "--out", out / "batch", "--jobs", "1"),
    }
    (out / "root" / "alice").mkdir(parents=True)
    for cap in ("ALL0000", "ALL0001", "ALL0002"):
        (out / "root" / "alice" / cap).symlink_to(d / cap, target_is_directory=True)
    codes = {k: motorid_ok(*args).code for k, args in runs.items()}
    inspect = motorid_ok("inspect", d / "ALL0000", d / "ALL0001", d / "ALL0002", "--json").out
    return out, codes, inspect


@pytest.mark.slow
def test_every_document_the_cli_writes_matches_its_schema(demo_run, documents):
    out, codes, inspect = documents
    assert all(c == 0 for c in codes.values()), codes
    _valid("model", json.loads((demo_run.folder / "model.json").read_text()))  # auto, three captures
    _valid("model", json.loads((out / "pinv.json").read_text()))
    _valid("model", json.loads((out / "velocity.json").read_text()))
    _valid("design", json.loads((out / "design.json").read_text()))
    _valid("simulation", json.loads((out / "sim.json").read_text()))
    _valid("modes", json.loads((out / "modes.json").read_text()))
    _valid("inspect", json.loads(inspect))
    rows = list(csv.DictReader((out / "batch" / "summary.csv").open()))
    assert rows
    for row in rows:
        _valid("batch-summary", row)


def test_the_front_door_writes_what_the_schema_says(demo_run):
    import motorid as mi

    d = demo_run.folder
    fit = mi.identify(mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001"), method="markov")
    _valid("model", json.loads(json.dumps(fit.to_dict())))
    assert fit.to_dict() == fit.to_json() == fit.model.to_dict()  # to_json: the older name
    des = mi.design(fit.model, damping=0.9, wn=4.0)
    _valid("design", json.loads(json.dumps(des.to_dict())))
    _valid("simulation", json.loads(json.dumps(mi.simulate(fit.model, des, duration_s=0.5).to_dict())))


def test_docs_formats_specifies_every_schema_and_its_required_keys():
    text = FORMATS.read_text()
    for name in SCHEMA_NAMES:
        s = schema(name)
        assert f"{name}.schema.json" in text, name
        assert s["$id"] in text, s["$id"]
        item = s.get("items", s)
        for key in item.get("required", []):
            assert f"`{key}`" in text, f"{name}: {key} not described in docs/formats.md"
