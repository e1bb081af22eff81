"""``motorid design … --discrete TS --emit c|python|matlab``: the code on stdout (compiles), the JSON's
``discrete`` object (valid, the same difference equations), one-line refusals naming the option."""

from __future__ import annotations

import json
import shutil
import subprocess

import control
import jsonschema
import numpy as np
import pytest
from clihelpers import motorid_ok

from motorid.schemas import schema

PARAMS = ["model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"]
OBSERVER = ["--poles=-6,-9", "--integral-pole=-5", "--integral", "--observer-poles=-50,-40"]


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("emit") / "m.json"
    motorid_ok(*PARAMS, "--json", out)
    return out


def _discrete_system(data: dict) -> control.StateSpace:
    d = data["discrete"]
    n = len(d["states"])
    a = np.array(d["Ad"], dtype=float).reshape(n, n)
    b = np.array(d["Bd"], dtype=float).reshape(n, len(d["inputs"]))
    c = np.array(d["Cd"], dtype=float).reshape(len(d["outputs"]), n)
    return control.ss(a, b, c, np.array(d["Dd"], dtype=float), d["ts_s"])


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc) on PATH")
def test_the_c_on_stdout_compiles_and_runs_the_jsons_difference_equations(model_file, tmp_path, run_cli):
    res = run_cli("design", model_file, *OBSERVER, "--discrete", "0.002", "--emit", "c", "--json", tmp_path / "d.json")
    assert res.code == 0, res.err
    assert res.out.startswith("/*") and "double motor_controller_step(" in res.out
    assert "gains per sensor" not in res.out and "gains per sensor" in res.err  # the printout went to stderr
    assert "discrete controller: TS = 0.002 s (500 Hz), zoh" in res.err
    data = json.loads((tmp_path / "d.json").read_text())
    jsonschema.Draft202012Validator(schema("design")).validate(data)
    assert data["discrete"]["inputs"] == ["r", "position"] and data["discrete"]["outputs"] == ["u"]
    assert data["discrete"]["states"] == ["x̂_position", "x̂_velocity", "z"]
    (tmp_path / "controller.c").write_text(res.out)
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "controller.c"\n'
        "int main(void)\n{\n    motor_controller_state s;\n    double r, y;\n    motor_controller_init(&s);\n"
        '    while (scanf("%lf %lf", &r, &y) == 2)\n        printf("%.17g\\n", motor_controller_step(&s, r, y));\n'
        "    return 0;\n}\n")
    exe = tmp_path / "ctl"
    subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-o", str(exe), "main.c"],
                   check=True, capture_output=True, cwd=tmp_path)
    k = np.arange(400)
    w = np.column_stack([np.where(k >= 10, 5.0, 0.0), 4.0 * np.sin(0.05 * k)])
    run = subprocess.run([str(exe)], input="\n".join(f"{a:.17g} {b:.17g}" for a, b in w) + "\n",
                         capture_output=True, text=True, check=True)
    u = np.array(run.stdout.split(), dtype=float)
    want = control.forced_response(_discrete_system(data), T=k * 0.002, U=w.T).outputs
    assert np.max(np.abs(u - np.ravel(want))) <= 1e-9


def test_python_to_a_file_with_the_force_rules(model_file, tmp_path, run_cli):
    out = tmp_path / "ctl.py"
    args = ("design", model_file, "--poles=-6,-9", "--discrete", "0.001", "--discrete-method", "tustin",
            "--emit", "python", "--emit-file", out)
    res = run_cli(*args)
    assert res.code == 0, res.err
    assert "k1 = " in res.out and f"Python code: {out}" in res.out and "def " not in res.out
    ns: dict = {}
    exec(out.read_text(), ns)
    x = ns["motor_controller_init"]()
    assert "discretised by tustin" in ns["__doc__"]
    # plain state feedback is a static gain: u = kr r − K x
    u = ns["motor_controller_step"](x, 1.0, 0.25, -2.0)
    design = json.loads(run_cli("design", model_file, "--poles=-6,-9", "--json", tmp_path / "d.json").out and
                        (tmp_path / "d.json").read_text())
    assert "discrete" not in design  # only with --discrete
    assert u == pytest.approx(design["kr"] - design["K"][0] * 0.25 + design["K"][1] * 2.0, rel=1e-12)
    again = run_cli(*args)
    assert again.code == 2 and "--force" in again.err
    assert run_cli(*args, "--force").code == 0


def test_matlab_on_stdout(model_file, run_cli):
    res = run_cli("design", model_file, "--poles=-6,-9", "--integral", "--integral-pole=-4", "--discrete", "0.01",
                  "--emit", "matlab")
    assert res.code == 0, res.err
    assert res.out.startswith("function [u, x] = motor_controller_step(x, r, position, velocity)")


@pytest.mark.parametrize(("args", "message"), [
    (["--discrete", "0"], "--discrete must be greater than 0, got 0"),
    (["--discrete", "-0.01"], "--discrete must be greater than 0"),
    (["--discrete", "0.5", "--observer-poles=-50,-40"], "--discrete 0.5 s is at or beyond the Nyquist limit"),
    (["--discrete", "0.04"], "--discrete 0.04 s: the sampled loop is unstable"),
    (["--emit", "c"], "--emit needs --discrete TS"),
    (["--discrete", "0.01", "--emit", "rust"], "--emit 'rust': use one of c, python, matlab"),
    (["--discrete", "0.01", "--discrete-method", "magic"], "--discrete-method 'magic': use one of zoh"),
    (["--discrete", "0.01", "--emit-file", "x.c"], "--emit-file needs --emit"),
])
def test_bad_code_options_are_one_line(model_file, run_cli, args, message):
    poles = "--poles=-30,-35" if "0.04" in args else "--poles=-6,-9"
    res = run_cli("design", model_file, poles, *args)
    assert res.code == 2, (res.out, res.err)
    assert message in res.err and len(res.err.strip().splitlines()) == 1
