"""The fast tests on every other Python 3.11+ the machine has (3.12 and 3.13 here), as the CI
matrices of numpy, scipy and python-control run theirs: a fresh venv per interpreter, the
package installed from this tree with its test extra, ``pytest -m "not slow"``."""

from __future__ import annotations

import glob
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: The interpreters besides the one running this suite (which runs every test itself).
OTHERS = tuple(v for v in ("3.12", "3.13") if v != f"{sys.version_info.major}.{sys.version_info.minor}")
#: pip's words when the package index cannot be reached (an offline machine): skip, not fail.
OFFLINE = ("Could not find a version", "No matching distribution", "Failed to establish a new connection",
           "Temporary failure in name resolution", "Network is unreachable")


def _interpreter(version: str) -> str | None:
    """A working ``python3.12``: on the PATH, or a pyenv build (a pyenv shim of an inactive version
    is on the PATH but does not run, so each candidate is tried)."""
    builds = sorted(glob.glob(str(Path.home() / ".pyenv" / "versions" / f"{version}.*" / "bin" / "python")))
    for exe in (*reversed(builds), shutil.which(f"python{version}")):
        if exe and subprocess.run([exe, "-c", "import venv"], capture_output=True, timeout=60).returncode == 0:
            return exe
    return None


@pytest.mark.slow
@pytest.mark.parametrize("version", OTHERS)
def test_the_fast_tests_pass_on_another_python(version, tmp_path):
    exe = _interpreter(version)
    if exe is None:
        pytest.skip(f"no Python {version} on this machine")
    env_dir = tmp_path / "venv"
    subprocess.run([exe, "-m", "venv", str(env_dir)], check=True, timeout=300)
    python = str(env_dir / "bin" / "python")
    pip = subprocess.run([python, "-m", "pip", "install", "-q", f"{REPO}[test]"], capture_output=True, text=True,
                         timeout=1800)
    if pip.returncode != 0 and any(word in pip.stderr for word in OFFLINE):
        pytest.skip(f"the package index is out of reach: {pip.stderr.strip().splitlines()[-1]}")
    assert pip.returncode == 0, pip.stderr[-2000:]
    run = subprocess.run([python, "-m", "pytest", "-m", "not slow", "-q", "-x", "-p", "no:cacheprovider",
                          "-p", "no:warnings", str(REPO / "tests")], capture_output=True, text=True,
                         cwd=tmp_path, timeout=3600)
    assert run.returncode == 0, f"Python {version}:\n" + run.stdout[-4000:] + run.stderr[-2000:]
