"""The README's first command on the core install: a fresh venv, ``pip install .`` (no extras),
``motorid demo``, ``motorid --version`` and ``import motorid as mi`` — as a newcomer runs them."""

from __future__ import annotations

import subprocess
import sys
import venv
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: pip's words when the package index cannot be reached (an offline machine): skip, not fail.
OFFLINE = ("Could not find a version", "No matching distribution", "Failed to establish a new connection",
           "Temporary failure in name resolution", "Network is unreachable")


@pytest.mark.slow
def test_the_demo_runs_on_the_core_install(tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    bin_dir = env_dir / ("Scripts" if sys.platform == "win32" else "bin")
    pip = subprocess.run([str(bin_dir / "python"), "-m", "pip", "install", "-q", str(REPO)],
                         capture_output=True, text=True, timeout=900)
    if pip.returncode != 0 and any(word in pip.stderr for word in OFFLINE):
        pytest.skip(f"the package index is out of reach: {pip.stderr.strip().splitlines()[-1]}")
    assert pip.returncode == 0, pip.stderr[-2000:]
    listed = subprocess.run([str(bin_dir / "python"), "-m", "pip", "list", "--format=freeze"],
                            capture_output=True, text=True, check=True).stdout.lower()
    for extra in ("fastapi", "pyvisa", "dask", "pytest", "sphinx"):  # the extras stay out of the core
        assert f"\n{extra}==" not in "\n" + listed, extra
    demo = subprocess.run([str(bin_dir / "motorid"), "demo", "--out", str(tmp_path / "d")], capture_output=True,
                          text=True, cwd=tmp_path, timeout=600)
    assert demo.returncode == 0, demo.stderr[-2000:]
    assert (tmp_path / "d" / "report.html").is_file() and (tmp_path / "d" / "model.json").is_file()
    version = subprocess.run([str(bin_dir / "motorid"), "--version"], capture_output=True, text=True, check=True)
    imported = subprocess.run([str(bin_dir / "python"), "-c", "import motorid as mi; print(mi.__version__)"],
                              capture_output=True, text=True, check=True, cwd=tmp_path)
    assert version.stdout.strip() == f"motorid {imported.stdout.strip()}"
