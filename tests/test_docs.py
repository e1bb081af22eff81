"""The tutorial's code blocks run, in order, in a fresh folder (issue 6)."""

import re

import pytest

from conftest import REPO


def test_tutorial_code_blocks_run(tmp_path, monkeypatch, capsys):
    text = (REPO / "docs" / "tutorial.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"tutorial block {i + 1}", "exec"), namespace)
    assert (tmp_path / "report.html").is_file()
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
