"""Ctrl-C is not success: SIGINT ends a command with exit 130 and one line saying so."""

from __future__ import annotations

import signal
import subprocess
import sys
import time


def _default_sigint() -> None:
    # a shell that started the tests in the background ignores SIGINT, and the ignore is inherited
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_sigint_exits_130_with_one_line(tmp_path):
    proc = subprocess.Popen([sys.executable, "-m", "motorid", "demo", "--out", str(tmp_path / "d")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                            preexec_fn=_default_sigint)
    time.sleep(1.5)  # inside the command (imports take about 1 s), before the demo is written
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (proc.returncode, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines == ["motorid: interrupted"], err
