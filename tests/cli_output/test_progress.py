"""Progress bars: the library reports through a callback, the CLI draws on stderr.

No bar unless stderr is a terminal or ``--progress`` is given; the callbacks' sequence is
checked, not the drawing speed (no sleeps).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from motorid.cli.progress import progress_bar, wanted

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow


def test_disabled_bar_ignores_every_call(capsys) -> None:
    with progress_bar("x", total=3, enabled=False) as cb:
        cb(1)
        cb(2, 5, label="b")
    assert not cb.enabled
    assert capsys.readouterr().err == ""
    assert wanted(True) and wanted(False) == sys.stderr.isatty()


def test_enabled_bar_draws_label_and_count_on_stderr(capsys) -> None:
    with progress_bar("x", total=3, enabled=True, force_terminal=True) as cb:
        cb(1, label="a")
        cb(2, label="b")
    cap = capsys.readouterr()
    assert cb.enabled and cap.out == ""
    assert "x: b" in cap.err and "2/3" in cap.err


def test_run_demo_reports_each_step_in_order(tmp_path) -> None:
    from motorid.cli.demo import DEMO_STEPS, run_demo

    calls: list[tuple] = []
    run_demo(tmp_path / "d", seed=3, progress=lambda *a: calls.append(a))
    n = len(DEMO_STEPS)
    assert calls == [(i, n, DEMO_STEPS[i]) for i in range(n)] + [(n, n, None)]


def test_progress_flag_draws_on_a_pipe_and_stdout_is_unchanged(tmp_path) -> None:
    model = tmp_path / "m.json"
    base = [sys.executable, "-m", "motorid"]
    subprocess.run([*base, "model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36",
                    "--k0", "0.25", "--Tm", "0.55", "--json", str(model)], check=True, capture_output=True)
    args = ["modes", str(model), "--kp", "0:200:12", "--kv", "0:10:12"]
    env = {**os.environ, "COLUMNS": "120"}
    plain = subprocess.run([*base, *args], capture_output=True, text=True, env=env, check=True)
    shown = subprocess.run([*base, "--progress", *args], capture_output=True, text=True, env=env, check=True)
    assert plain.stderr == ""  # a pipe without --progress: no bar
    assert "mode maps" in shown.stderr and "/" in shown.stderr
    strip = [line.rsplit("(", 1)[0] for line in plain.stdout.splitlines()]  # the timing differs run to run
    assert strip == [line.rsplit("(", 1)[0] for line in shown.stdout.splitlines()]
