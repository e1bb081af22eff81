"""The tutorial runs, block by block, in a fresh folder, and prints what it says it prints.

Every ```python block runs in order in one namespace; a ```text block after a python block
is that block's expected output: each of its lines must appear among the printed lines, with
its numbers within 1 % (or 1e-3). Each ```bash line starting with ``motorid`` runs through the
real entry point. Then the key numbers are checked against the trainer's truth, which the
tutorial's own output cannot influence.
"""

import contextlib
import io
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]

FENCE = re.compile(r"```(python|text|bash)\n(.*?)```", flags=re.S)
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def _matches(expected: str, printed: str) -> bool:
    if NUMBER.sub("#", expected).strip() != NUMBER.sub("#", printed).strip():
        return False
    for a, b in zip(NUMBER.findall(expected), NUMBER.findall(printed), strict=True):
        if float(b) != pytest.approx(float(a), rel=0.01, abs=1e-3):
            return False
    return True


def _run_cli(line: str, monkeypatch) -> None:
    from motorid.cli.app import main

    monkeypatch.setattr(sys, "argv", shlex.split(line))
    with pytest.raises(SystemExit) as exc:
        main()
        raise SystemExit(0)
    assert exc.value.code in (0, None), line


@pytest.mark.slow
def test_tutorial_blocks_run_and_print_what_they_say(tmp_path, monkeypatch):
    text = (REPO / "docs" / "tutorial.md").read_text(encoding="utf-8")
    blocks = FENCE.findall(text)
    assert sum(kind == "python" for kind, _ in blocks) >= 12
    assert sum(kind == "text" for kind, _ in blocks) >= 3
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    printed: list[str] = []
    checked = 0
    for i, (kind, body) in enumerate(blocks):
        if kind == "python":
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(body, f"tutorial block {i + 1}", "exec"), namespace)
            printed = out.getvalue().splitlines()
        elif kind == "text":
            for line in filter(None, body.splitlines()):
                assert any(_matches(line, p) for p in printed), (line, printed)
                checked += 1
        else:
            for line in body.splitlines():
                if line.startswith("motorid "):
                    _run_cli(line, monkeypatch)
    assert checked >= 5
    assert (tmp_path / "report.html").is_file() and (tmp_path / "own-design.json").is_file()
    # the numbers the tutorial shows, against the trainer's truth (independent of our output):
    # the paper's pinv at its 100 ms within 2 % in DC gain; auto within 0.5 % of the gain a
    # step shows (linear × (1 − offset/step)), its interval covering the linear τ
    exp, paper, best = namespace["exp"], namespace["paper"], namespace["best"]
    assert paper.conditioned.sample_interval_s == pytest.approx(0.1, rel=1e-6)
    effective = exp.truth.dc_gain * (1 - exp.truth.equivalent_input_offset_v / exp.step_volts)
    assert paper.model.first_order().dc_gain == pytest.approx(effective, rel=0.02)
    assert best.model.first_order().dc_gain == pytest.approx(effective, rel=0.005)
    lo, hi = best.model.uncertainty["time_constant"]["ci95"]
    assert lo <= exp.truth.time_constant_s <= hi
    assert namespace["again"].to_json() == best.model.to_json()
    # part 2: the designs do what they were asked, on the identified model
    # a double pole: the eigenvalues of A − BK split by ~√(rounding) about it; their mean is exact
    slow = sorted(namespace["sf"].closed_loop_poles, key=lambda p: p.real)[-2:]
    assert np.mean(slow).real == pytest.approx(-4.0, abs=1e-6) and abs(slow[0] - slow[1]) < 1e-3
    assert abs(namespace["run_i"].metrics.steady_state_error_v) < 0.01
    assert abs(namespace["run"].metrics.steady_state_error_v) > 10 * abs(namespace["run_i"].metrics.steady_state_error_v)
    # part 3: the synthetic log's truth is 240 rpm/V and 0.3 s
    own = namespace["own"]
    assert own.params["dc_gain"].value == pytest.approx(240.0, rel=0.01)
    assert own.params["time_constant"].value == pytest.approx(0.3, rel=0.03)
