"""One way in: the same captures through the command line, ``mi.identify``, ``POST /api/identify``
and ``motorid batch`` give the same model JSON (apart from where the files were read from).

Every front end calls the front door; a drift between them (an option defaulted differently,
a capture read differently, a role added by one of them) shows here as a key that differs.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from clihelpers import motorid_ok

import motorid as mi
from motorid.io import write_tds_capture
from motorid.trainer import PRESET_NAMES, run_experiment
from motorid.trainer.realsetups import write_real_setup

#: The rigs whose files the trainer writes as those rigs do, the demo's scope folders (the paper
#: preset) and every other trainer preset's captures written as the scope saves them.
CASES = ("demo", "l298n-rpm", "l298n-rpm:counted", "arduino-millis", "host-loop", "encoder-counts", "pwm-encoder",
         "pwm-encoder:counted", "daq-deadtime", "ms-time", "fast-tbs1000", "staircase", "serial-plotter", "picoscope", "clock-stamps", "no-header",
         *(f"trainer:{p}" for p in PRESET_NAMES if p != "paper"))


def _without_provenance(doc: dict, files: list[Path]) -> dict:
    """The document with every path to an input file cut to the file's name (the front ends read
    the same bytes from different folders: an upload folder, a batch tree)."""
    text = json.dumps(doc, sort_keys=True)
    for name in {f.name for f in files}:
        text = re.sub(r'(?:/[^"/\s]+)+/' + re.escape(name), name, text)
    return json.loads(text)


def _captures(case: str, demo_run, tmp_path: Path) -> tuple[dict[str, list[Path]], dict[str, float]]:
    """Each role's file(s) and the read options (a step level for captures without an input)."""
    if case == "demo":
        d = demo_run.folder
        return {role: sorted((d / f"ALL000{i}").glob("*.CSV"))
                for i, role in enumerate(("position", "velocity", "current"))}, {}
    if case.startswith("trainer:"):
        exp = run_experiment(case.split(":", 1)[1], seed=0)
        return {role: sorted(write_tds_capture(tmp_path / case.replace(":", "-"), cap, index=i).glob("*.CSV"))
                for i, (role, cap) in enumerate(exp.captures.items())}, {}
    rig, _, counted = case.partition(":")
    rec = write_real_setup(rig, tmp_path / rig, seed=0)
    args = list(rec.cli_args)
    roles = {args[i][2:]: [Path(args[i + 1])] for i in range(0, len(args), 2)
             if args[i] in ("--position", "--velocity", "--current")}
    opts: dict[str, float | int | bool] = {}
    if counted:  # the rig's speed column counts encoder edges over each line (pwm-encoder: over five, held)
        opts["counted_velocity"] = True
    if "--step-volts" in args:
        opts["step_volts"] = float(args[args.index("--step-volts") + 1])
    if "--segment" in args:  # one step of a staircase log, picked the same way by every front end
        opts["segment"] = int(args[args.index("--segment") + 1])
    if "--columns" in args:  # a PicoScope's channels A and B, named by the user
        opts["columns"] = args[args.index("--columns") + 1]
    return roles, opts


def _python(opts: dict) -> dict:
    """The read options as Python takes them (a column map is a dict)."""
    out = dict(opts)
    if "columns" in out:
        out["columns"] = dict(p.split("=", 1) for p in out["columns"].split(","))
    return out


def _toml(key: str, value: object) -> str:
    """One ``experiment.toml`` line (a column map is an inline table)."""
    if key == "columns":
        pairs = dict(p.split("=", 1) for p in str(value).split(","))
        return "columns = {" + ", ".join(f'{k} = "{v}"' for k, v in pairs.items()) + "}"
    return f"{key} = {json.dumps(value)}" if isinstance(value, bool) else f"{key} = {value!r}"


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES)
def test_cli_python_web_and_batch_give_the_same_model(case, demo_run, tmp_path):
    roles, opts = _captures(case, demo_run, tmp_path)
    files = [f for fs in roles.values() for f in fs]

    def spec(fs: list[Path]) -> str:
        return "+".join(map(str, fs)) if len(fs) > 1 else str(fs[0])

    # the command line
    flags = [x for role, fs in roles.items() for x in (f"--{role}", spec(fs))]
    flags += [x for k, v in opts.items() for x in ((f"--{k.replace('_', '-')}",) if v is True
                                                   else (f"--{k.replace('_', '-')}", str(v)))]
    motorid_ok("identify", *flags, "--json", tmp_path / "cli.json")
    by_cli = _without_provenance(json.loads((tmp_path / "cli.json").read_text()), files)

    # Python
    exp = mi.read_experiment(**{role: fs if len(fs) > 1 else fs[0] for role, fs in roles.items()}, **_python(opts))
    assert _without_provenance(mi.identify(exp).model.to_json(), files) == by_cli

    # the web page's API
    pytest.importorskip("fastapi", reason="the web extra is not installed")
    from fastapi.testclient import TestClient

    from motorid.web import WebSettings, create_app

    (tmp_path / "web").mkdir()
    with TestClient(create_app(WebSettings(temp_root=tmp_path / "web")), base_url="http://127.0.0.1") as client:
        upload = [(role, (f.name, f.read_bytes(), "text/csv")) for role, fs in roles.items() for f in fs]
        res = client.post("/api/identify", files=upload, data={k: str(v) for k, v in opts.items()})
    assert res.status_code == 200, res.text
    assert _without_provenance(res.json(), files) == by_cli

    # a batch of one experiment, its roles named in experiment.toml
    folder = tmp_path / "class" / "alice"
    folder.mkdir(parents=True)
    toml = []
    for role, fs in roles.items():
        for f in fs:
            shutil.copy(f, folder / f.name)
        toml.append(f'{role} = "{"+".join(f.name for f in fs)}"')
    toml += [_toml(k, v) for k, v in opts.items()]
    (folder / "experiment.toml").write_text("\n".join(toml) + "\n")
    motorid_ok("batch", tmp_path / "class", "--out", tmp_path / "out", "--jobs", "1")
    by_batch = json.loads((tmp_path / "out" / "alice" / "model.json").read_text())
    assert _without_provenance(by_batch, files) == by_cli


#: What the front ends must reach through the front door, never directly: the estimators'
#: pipeline, the several-levels fit, the designers and the closed-loop simulators.
_BELOW_THE_FRONT_DOOR = {
    "motorid.identification.pipeline": {"identify_experiment"},
    "motorid.identification.hammerstein": {"identify_levels"},
    "motorid.control.design": {"design_controller"},
    "motorid.control.pid": {"design_pid"},
    "motorid.simulation.closed_loop": {"simulate_closed_loop"},
    "motorid.trainer.closed_loop": {"simulate_on_trainer"},
}


def _calls_below_the_front_door(path: Path) -> list[str]:
    import ast

    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module in _BELOW_THE_FRONT_DOOR:
            found += [f"{path.name}:{node.lineno} {node.module}.{a.name}" for a in node.names
                      if a.name in _BELOW_THE_FRONT_DOOR[node.module]]
    return found


@pytest.mark.parametrize("front_end", ["cli", "web", "batch"])
def test_the_front_ends_identify_design_and_simulate_through_the_front_door(front_end):
    src = Path(mi.__file__).parent / front_end
    found = [hit for path in sorted(src.rglob("*.py")) for hit in _calls_below_the_front_door(path)]
    assert not found, found


def test_the_scan_sees_a_call_below_the_front_door(tmp_path):
    # the check above can fail: an import of the pipeline's own entry point is found
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from motorid.identification.pipeline import identify_experiment\n")
    assert _calls_below_the_front_door(bad) == ["bad.py:2 motorid.identification.pipeline.identify_experiment"]
