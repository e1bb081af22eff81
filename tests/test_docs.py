"""The tutorial's code blocks run, in order, in a fresh folder (issue 6)."""

import re

from conftest import REPO


def test_tutorial_code_blocks_run(tmp_path, monkeypatch, capsys):
    text = (REPO / "docs" / "tutorial.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"tutorial block {i + 1}", "exec"), namespace)  # noqa: S102 - our own docs
    assert (tmp_path / "report.html").is_file()
