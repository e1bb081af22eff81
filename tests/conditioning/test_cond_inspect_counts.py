"""``motorid inspect`` says what a log's whole counts mean for ``identify``, in its table's notes and JSON."""

from __future__ import annotations

import json

import jsonschema
import pytest

from motorid.schemas import schema
from motorid.trainer.realsetups import write_real_setup


@pytest.mark.parametrize(("rig", "hold", "over_stamps"), [("l298n-rpm", 1, False), ("pwm-encoder", 5, False),
                                                         ("clock-stamps", 1, True)])
def test_inspect_reports_a_speed_in_whole_counts(rig, hold, over_stamps, tmp_path, run_cli):
    rec = write_real_setup(rig, tmp_path / rig, seed=0)
    res = run_cli("inspect", rec.files["log"], "--json")
    assert res.code == 0, res.err
    doc = json.loads(res.out)
    jsonschema.validate(doc, schema("inspect"))
    counts = doc[0]["counts"]
    assert counts["hold"] == hold and counts["over_stamps"] == over_stamps and counts["step"] > 0
    said = " ".join(run_cli("inspect", rec.files["log"]).out.split())
    assert ("identify fits it so" in said) == over_stamps
    assert ("hold the counted reading too" in said) == (not over_stamps)


def test_inspect_says_nothing_of_counts_for_volts_or_positions(tmp_path, run_cli):
    """A scope's 8-bit codes in volts (a tacho, sampled) and an encoder's position in counts are not a
    counted speed: no ``counts`` key."""
    for rig, extra in (("fast-tbs1000", ()), ("encoder-counts", ())):
        rec = write_real_setup(rig, tmp_path / rig, seed=0)
        files = [str(p) for p in rec.files.values()]
        res = run_cli("inspect", *files, *extra, "--json")
        assert res.code == 0, res.err
        assert all("counts" not in d for d in json.loads(res.out)), rig
