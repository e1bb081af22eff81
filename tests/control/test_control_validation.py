"""Everyday mistakes on ``design``/``simulate``/``modes``/``model``: exit 2, one line, nothing written.

Hardening: every option and input file is validated before
any work starts; the real entry point (``motorid.cli.app:main``, via the ``run_cli`` fixture)
maps the errors to exit code 2 with one line on stderr and no traceback.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from motorid.control.design import DesignSettings, design_controller
from motorid.control.params import MotorParams, model_from_params
from motorid.model import model_from_velocity_tf


@pytest.fixture()
def files(tmp_path) -> dict[str, Path]:
    two = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    one = model_from_velocity_tf([1.64], [1.0, 1.82], method="test")
    out = {"two": tmp_path / "two.json", "one": tmp_path / "one.json", "design": tmp_path / "d.json"}
    out["two"].write_text(two.to_json_text())
    out["one"].write_text(one.to_json_text())
    out["design"].write_text(design_controller(two, DesignSettings(damping=1.0, k2=8.5)).to_json_text())
    return out


def _refused(res, *words: str) -> None:
    assert res.code == 2, (res.code, res.out, res.err)
    lines = res.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.err, res.err
    for w in words:
        assert w in lines[0], lines[0]


def _nothing_new(folder: Path, before: set[str]) -> None:
    assert {p.name for p in folder.iterdir()} == before


def test_png_must_be_a_png(files, run_cli, tmp_path):
    before = {p.name for p in tmp_path.iterdir()}
    _refused(run_cli("simulate", files["two"], files["design"], "--png", tmp_path / "x.txt"), "--png", ".png")
    _refused(run_cli("modes", files["two"], "--kp", "0:10:3", "--kv", "0:2:3", "--png", tmp_path / "m.jpg"), ".png")
    _nothing_new(tmp_path, before)


def test_png_overwrite_check_looks_at_the_file_really_written(files, run_cli, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "plot.png").write_bytes(b"keep")
    # a bare name would have been written as plot.png by matplotlib, past the --force check
    _refused(run_cli("simulate", files["two"], files["design"], "--png", out / "plot"), ".png")
    _refused(run_cli("simulate", files["two"], files["design"], "--png", out / "plot.png"), "already exists")
    _refused(run_cli("modes", files["two"], "--kp", "0:10:3", "--kv", "0:2:3", "--png", out / "plot.png"),
             "already exists")
    assert (out / "plot.png").read_bytes() == b"keep"
    res = run_cli("simulate", files["two"], files["design"], "--png", out / "plot.png", "--force", "--duration", "1")
    assert res.code == 0, res.err
    assert (out / "plot.png").read_bytes()[:4] == b"\x89PNG"


def test_output_into_missing_folder_or_onto_a_folder(files, run_cli, tmp_path):
    before = {p.name for p in tmp_path.iterdir()}
    _refused(run_cli("design", files["two"], "--poles", "-5,-6", "--json", tmp_path / "nope" / "d.json"),
             "does not exist")
    _refused(run_cli("design", files["two"], "--poles", "-5,-6", "--json", tmp_path), "folder")
    _refused(run_cli("simulate", files["two"], files["design"], "--csv", tmp_path / "nope" / "s.csv"), "--csv")
    _refused(run_cli("model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25",
                     "--Tm", "0.55", "--json", tmp_path / "nope" / "m.json"), "does not exist")
    _nothing_new(tmp_path, before)


def test_damping_wn_on_a_one_state_model(files, run_cli, tmp_path):
    _refused(run_cli("design", files["one"], "--damping", "0.7", "--wn", "5", "--json", tmp_path / "o.json"),
             "one state", "--poles")
    _refused(run_cli("design", files["one"], "--settling-time", "1", "--overshoot", "5"), "one state")
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("args, words", [
    (["--poles", "1e308,-1e308"], ("--poles", "absurd")),
    (["--poles", "-1e7,-5"], ("--poles", "absurd")),
    (["--poles", "nan,-5"], ("--poles", "finite")),
    (["--poles", "1e309,-5"], ("--poles", "finite")),
    (["--poles", "-5,abc"], ("--poles",)),
    (["--damping", "0.7", "--wn", "nan"], ("--wn",)),
    (["--damping", "0.7", "--wn", "1e300"], ("--wn", "absurd")),
    (["--damping", "-1", "--wn", "5"], ("--damping",)),
    (["--poles", "-5,-6", "--wn", "5"], ("--wn",)),
    (["--poles", "-5,-6", "--observer-poles", "-1e308,-40"], ("--observer-poles", "absurd")),
    (["--poles", "-5,-6", "--integral", "--integral-pole", "-1e300"], ("--integral-pole", "absurd")),
    (["--poles", "-5,-6", "--output", "torque"], ("--output",)),
])
def test_absurd_or_malformed_poles(files, run_cli, tmp_path, args, words):
    _refused(run_cli("design", files["two"], *args, "--json", tmp_path / "o.json"), *words)
    assert not (tmp_path / "o.json").exists()


def test_deeply_nested_json_files(files, run_cli, tmp_path):
    deep = "[" * 200_000 + "]" * 200_000
    bad_model = tmp_path / "deep_model.json"
    bad_model.write_text('{"schema": "motorid.model/1", "method": "x", "states": ' + deep + "}")
    _refused(run_cli("design", bad_model, "--poles", "-5,-6"), "deep_model.json")
    bad_design = tmp_path / "deep_design.json"
    bad_design.write_text('{"schema": "motorid.design/1", "states": ' + deep + "}")
    _refused(run_cli("simulate", files["two"], bad_design), "deep_design.json")
    # nested, but shallow enough for the JSON parser: a matrix of lists of lists
    odd = json.loads(files["two"].read_text())
    odd["state_space"]["A"] = [[[[1.0]]] * 2] * 2
    bad_model.write_text(json.dumps(odd))
    _refused(run_cli("design", bad_model, "--poles", "-5,-6"), "deep_model.json")


@pytest.mark.parametrize("key, value, word", [
    ("K", [1.0], "'K'"),
    ("K", ["a", 2.0], "'K'"),
    ("K", [1e999, 2.0], "'K'"),
    ("kr", "x", "'kr'"),
    ("L", [1.0, 2.0, 3.0], "'L'"),
    ("states", "position", "'states'"),
    ("closed_loop_poles", [[1.0]], "'closed_loop_poles'"),
    ("transform", [[1.0, 0.0]], "'model_states'"),
    ("schema", "motorid.model/1", "schema"),
])
def test_malformed_design_json(files, run_cli, tmp_path, key, value, word):
    data = json.loads(files["design"].read_text())
    data[key] = value
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    _refused(run_cli("simulate", files["two"], bad, "--json", tmp_path / "s.json"), "bad.json", word)
    assert not (tmp_path / "s.json").exists()


def test_simulate_options_checked_before_reading_files(run_cli, tmp_path):
    # the files do not exist: the option errors come first
    _refused(run_cli("simulate", tmp_path / "m.json", tmp_path / "d.json", "--reference", "ramp"), "--reference")
    _refused(run_cli("simulate", tmp_path / "m.json", tmp_path / "d.json", "--plant", "trainer", "--preset", "nope"),
             "preset")
    _refused(run_cli("simulate", tmp_path / "m.json", tmp_path / "d.json", "--dt", "0"), "--dt")


def test_design_on_another_models_states_is_refused(files, run_cli, tmp_path):
    from motorid.model import MotorModel

    other = MotorModel(A=np.diag([-1.0, -2.0, -3.0]), B=[[1.0], [1.0], [1.0]], C=[[1.0, 1.0, 1.0]],
                       D=[[0.0]], states=("x1", "x2", "x3"), outputs=("velocity",))
    path = tmp_path / "other.json"
    path.write_text(other.to_json_text())
    _refused(run_cli("simulate", path, files["design"]), "design")
