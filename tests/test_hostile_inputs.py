"""Inputs that used to be internal errors are one-line refusals (exit 2, HTTP 422)."""

from __future__ import annotations

import json

import pytest


@pytest.fixture
def model_text(demo_run) -> str:
    return (demo_run.folder / "model.json").read_text()


@pytest.mark.parametrize("command", [["design", "--poles", "-5,-6,-7,-8"], ["modes", "--kp", "0:10:3", "--kv", "0:1:3"]])
def test_a_model_with_a_5000_digit_integer_is_refused(tmp_path, model_text, run_cli, command):
    bad = tmp_path / "big.json"
    doc = json.loads(model_text)
    bad.write_text(model_text.replace(json.dumps(doc["step_volts"]), "9" * 5000, 1))
    res = run_cli(command[0], bad, *command[1:])
    assert res.code == 2 and "not a motorid model" in res.err and "internal error" not in res.err


def test_a_model_with_absurd_entries_is_refused(tmp_path, model_text, run_cli):
    doc = json.loads(model_text)
    doc["state_space"]["A"][0][0] = 1e308
    bad = tmp_path / "huge.json"
    bad.write_text(json.dumps(doc))
    res = run_cli("modes", bad, "--kp", "0:10:3", "--kv", "0:1:3")
    assert res.code == 2 and "not a motor's model" in res.err


def test_a_json_nested_100000_deep_is_refused(tmp_path, run_cli):
    bad = tmp_path / "nested.json"
    bad.write_text('{"schema": "motorid.model/1", "x": ' + "[" * 100_000 + "]" * 100_000 + "}")
    res = run_cli("design", bad, "--poles", "-5")
    assert res.code == 2 and "nested too deeply" in res.err


def test_markov_params_are_bounded_by_the_data(demo_run, run_cli):
    res = run_cli("identify", "--velocity", demo_run.folder / "ALL0001", "--method", "markov",
                  "--markov-params", "100000")
    assert res.code == 2 and "--markov-params 100000: at most" in res.err


def test_the_web_api_refuses_a_body_nested_too_deeply(demo_run):
    pytest.importorskip("fastapi", reason="the web extra is not installed")
    from fastapi.testclient import TestClient

    from motorid.web import WebSettings, create_app

    with TestClient(create_app(WebSettings()), base_url="http://127.0.0.1") as client:
        res = client.post("/api/design", content="[" * 100_000 + "]" * 100_000,
                          headers={"Content-Type": "application/json"})
    assert res.status_code == 422 and "nested too deeply" in res.json()["detail"]


def test_write_report_refuses_an_unknown_simulation_option(demo_run, tmp_path):
    import motorid as mi

    fit = mi.identify(mi.read_experiment(velocity=demo_run.folder / "ALL0001"), method="pinv")
    des = mi.design(fit.model, poles=[-5])
    with pytest.raises(mi.MotorIdError, match=r"^simulation=\{'durationn': …\}: not an option of simulate; use "):
        mi.write_report(tmp_path / "r.html", fit, design=des, simulation={"durationn": 3})
    assert not (tmp_path / "r.html").exists()
