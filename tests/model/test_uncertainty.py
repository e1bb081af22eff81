"""The typed uncertainty: one writer and one reader of the model JSON's ``uncertainty`` and ``timing``."""

from __future__ import annotations

import json
import pickle
import re
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pytest

from motorid.errors import ModelFormatError
from motorid.model import MotorModel, model_from_velocity_tf
from motorid.model.uncertainty import ChannelTiming, JointCovariance, ParameterEstimate, Uncertainty

SRC = Path(__file__).resolve().parents[2] / "src" / "motorid"


def _doc(demo_run) -> dict:
    return json.loads((demo_run.folder / "model.json").read_text())


def test_a_fits_json_reads_into_types_and_writes_back_the_same_text(demo_run):
    doc = _doc(demo_run)
    model = MotorModel.from_json(doc)
    u = model.uncertainty
    assert isinstance(u, Uncertainty)
    assert isinstance(u.dc_gain, ParameterEstimate) and isinstance(u.dc_gain.value, float)
    lo, hi = u.dc_gain.ci95
    assert lo < u.dc_gain.value < hi and u.dc_gain.stderr > 0
    assert u.dc_gain.structure_std == doc["uncertainty"]["dc_gain"].get("structure_std")
    assert all(isinstance(p.value, complex) for p in u.poles)
    assert [[p.value.real, p.value.imag] for p in u.poles] == [p["value"] for p in doc["uncertainty"]["poles"]]
    assert isinstance(u.joint, JointCovariance) and not u.joint.covariance.flags.writeable
    assert u.joint.covariance.shape == (len(u.joint.parameters),) * 2
    assert all(isinstance(t, ChannelTiming) for t in u.timing.values())
    assert set(u.timing) == set(doc["timing"])
    # one serializer: the same JSON text back
    assert json.dumps(model.to_dict(), sort_keys=True) == json.dumps(doc, sort_keys=True)


def test_the_mapping_view_is_the_json_object(demo_run):
    doc = _doc(demo_run)
    u = MotorModel.from_json(doc).uncertainty
    assert u["dc_gain"]["ci95"] == pytest.approx(doc["uncertainty"]["dc_gain"]["ci95"])
    assert set(u) == set(doc["uncertainty"]) | {"timing"}
    assert dict(u) == u.to_dict()


def test_it_pickles_with_its_mappings_read_only(demo_run):
    u = MotorModel.from_json(_doc(demo_run)).uncertainty
    back = pickle.loads(pickle.dumps(u))
    assert back == u
    assert isinstance(back.timing, MappingProxyType) and isinstance(back.other, MappingProxyType)


def test_what_it_does_not_type_is_kept_and_written_back():
    data = {"dc_gain": {"value": 2.0, "std": None, "ci95": [None, None]},
            "joint": {"parameters": ["K", "log_tau_0"], "values": [1.0], "covariance": [[1.0]]},
            "vendor_key": {"x": 1}}
    u = Uncertainty.from_dict(data)
    assert u.dc_gain is not None and u.dc_gain.value == 2.0
    assert np.isnan(u.dc_gain.stderr) and u.dc_gain.ci95 is None  # null std and interval: not given
    assert u.joint is None  # its shapes disagree: not a covariance to draw motors from
    out = u.to_dict()
    assert out["joint"] == data["joint"] and out["vendor_key"] == {"x": 1}
    assert out["dc_gain"]["ci95"] == [pytest.approx(np.nan, nan_ok=True)] * 2


def test_the_quantised_channels_are_typed_and_written_back():
    # each channel whose intervals hold its quantiser's error, with its code step; a malformed entry is
    # not typed (no channel is claimed) and is written back as it was
    u = Uncertainty.from_dict({"method": "m", "quantiser": {"velocity": 0.08, "current": 0.04}})
    assert dict(u.quantiser) == {"velocity": 0.08, "current": 0.04}
    assert isinstance(u.quantiser, MappingProxyType) and "quantiser" not in u.other
    assert u.to_dict()["quantiser"] == {"velocity": 0.08, "current": 0.04}
    assert pickle.loads(pickle.dumps(u)).quantiser == u.quantiser
    assert "quantiser" not in Uncertainty.from_dict({"method": "m"}).to_dict()
    for bad in ({"velocity": -1.0}, {"velocity": "x"}, [0.08]):
        odd = Uncertainty.from_dict({"quantiser": bad})
        assert not odd.quantiser and odd.to_dict()["quantiser"] == bad


@pytest.mark.parametrize("key", ["onset_lag_s", "counting_lag_s"])
def test_the_timing_allowances_are_typed_and_written_back(key):
    u = Uncertainty.from_dict({"method": "m", key: 0.0025})
    assert getattr(u, key) == 0.0025 and u.to_dict()[key] == 0.0025 and key not in u.other
    assert getattr(pickle.loads(pickle.dumps(u)), key) == 0.0025
    assert key not in Uncertainty.from_dict({"method": "m"}).to_dict()
    for bad in (-1.0, "x", True, [0.1]):
        odd = Uncertainty.from_dict({key: bad})
        assert getattr(odd, key) == 0.0 and odd.to_dict()[key] == bad


def test_a_model_takes_a_mapping_or_none_and_refuses_anything_else():
    m = model_from_velocity_tf([2.0], [1.0, 2.0], step_volts=1.0)
    assert m.uncertainty is None
    assert m.replace(uncertainty={}).uncertainty is None
    typed = m.replace(uncertainty={"dc_gain": {"value": 1.0, "std": 0.1, "ci95": [0.8, 1.2]}}).uncertainty
    assert typed is not None and typed.dc_gain.ci95 == (0.8, 1.2)
    with pytest.raises(ModelFormatError, match="uncertainty"):
        m.replace(uncertainty=[1, 2])
    doc = m.to_dict()
    with pytest.raises(ModelFormatError, match="uncertainty must be an object"):
        MotorModel.from_json({**doc, "uncertainty": [1]})


def test_the_front_doors_params_are_the_models_typed_estimates(demo_run):
    import motorid as mi

    d = demo_run.folder
    fit_demo = mi.identify(mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001", current=d / "ALL0002"))
    u = fit_demo.model.uncertainty
    p = fit_demo.params
    assert p["dc_gain"].stderr == u.dc_gain.stderr and p["dc_gain"].ci95 == u.dc_gain.ci95
    assert p["dc_gain"].unit == fit_demo.model.dc_gain_unit
    for i, pole in enumerate(u.poles):
        got = p[f"pole_{i + 1}"].value
        assert got == (pole.value.real if pole.value.imag == 0 else pole.value)
        assert p[f"pole_{i + 1}"].stderr == pole.stderr


#: JSON keys of the blobs a model carries, and the one module that may read each back.
ONE_READER = {
    r"""\[\s*["'](ci95|std|structure_std|shift_s)["']\s*\]|\.get\(\s*["'](ci95|structure_std)["']""":
        {"model/uncertainty.py", "model/nonlinearity.py"},  # the static nonlinearity reads its own object
    r"""\[\s*["'](sigma|ar_order|pre_step_sigma)["']\s*\]|\.get\(\s*["'](use|ar_order|pre_step_sigma)["']""":
        {"identification/noise_json.py"},
    r"""\[\s*["'](checks|passed)["']\s*\]|\.get\(\s*["'](checks|passed)["']""":
        {"identification/sanity.py"},
}


@pytest.mark.parametrize("pattern", list(ONE_READER))
def test_each_json_blob_of_a_model_has_one_reader(pattern):
    """One reader: the uncertainty's, the noise model's and the sanity gate's JSON objects are
    indexed by key only in the module that defines their type."""
    allowed, regex = ONE_READER[pattern], re.compile(pattern)
    offenders = []
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC).as_posix()
        if rel in allowed:
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if regex.search(line):
                offenders.append(f"{rel}:{n}: {line.strip()}")
    assert not offenders, "\n".join(offenders)


def test_the_noise_model_and_the_sanity_gate_read_back_what_they_wrote(demo_run):
    from motorid.identification.noise_json import ChannelNoise, noise_of
    from motorid.identification.sanity import SanityCheck, SanityReport

    model = MotorModel.from_json(_doc(demo_run))
    noise = noise_of(model)
    assert noise and all(isinstance(n, ChannelNoise) for n in noise.values())
    assert {role: n.to_json() for role, n in noise.items()} == _doc(demo_run)["extras"]["noise"]
    assert any(n.scale_only for n in noise.values()) == any(
        n["use"] == "scale only" for n in _doc(demo_run)["extras"]["noise"].values())
    report = SanityReport((SanityCheck("a", True, "fine"), SanityCheck("b", False, "not fine")))
    back = SanityReport.from_json(json.loads(json.dumps(report.to_json())))
    assert back == report and back.failures == ("not fine",)
    assert SanityReport.from_json(None) == SanityReport() and SanityReport.from_json({"checks": 3}) == SanityReport()
    assert noise_of(model_from_velocity_tf([2.0], [1.0, 2.0])) == {}


@pytest.mark.parametrize(("edit", "message"), [
    (lambda u: [1], "uncertainty must be an object"),
    (lambda u: {**u, "pole_pairs": [{"poles": "x"}]}, "uncertainty:"),
])
def test_a_model_file_with_a_broken_uncertainty_is_one_line_and_exit_2(demo_run, tmp_path, run_cli, edit, message):
    doc = _doc(demo_run)
    doc["uncertainty"] = edit(doc["uncertainty"])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    r = run_cli("design", bad, "--damping", "1", "--wn", "8")
    assert r.code == 2
    assert message in r.err and str(bad) in r.err
    assert "Traceback" not in r.err and len(r.err.strip().splitlines()) == 1


def test_a_channels_timing_carries_its_kind_and_older_documents_get_it_from_their_words():
    """``kind`` (logged, sampled, onset, given) is written beside the words and read back; an entry written
    before it existed gets it from its words, including a log's stamp-resolution wording of "logged"."""
    from motorid.conditioning.response import STEP_TIMINGS
    from motorid.identification.stages import step_instant
    from motorid.model.uncertainty import TIMING_KINDS, TIMING_SOURCES, ChannelTiming

    assert TIMING_KINDS == STEP_TIMINGS and set(TIMING_SOURCES) == set(TIMING_KINDS)
    for kind, words in TIMING_SOURCES.items():
        t = ChannelTiming(words, 0.25, None, None, kind)
        assert t.to_dict()["kind"] == kind
        assert ChannelTiming.from_dict(t.to_dict()) == t
        old = {k: v for k, v in t.to_dict().items() if k != "kind"}
        assert ChannelTiming.from_dict(old).kind == kind
    # a log stamped by a 1 ms clock: its own wording, still "logged"
    from types import SimpleNamespace

    r = SimpleNamespace(timing="logged", stamp_resolution_s=1e-3, edge=SimpleNamespace(time_s=0.5), sample_interval_s=0.01)
    words, _ = step_instant(r)
    assert words != TIMING_SOURCES["logged"]
    assert ChannelTiming.from_dict({"step_instant": words, "edge_s": 0.5}).kind == "logged"
    assert ChannelTiming.from_dict({"step_instant": "something else", "edge_s": 0.5}).kind is None
