"""The documentation site builds with warnings as errors, and the gallery's examples run.

The build runs in a fresh process on a copy of ``docs/`` and ``examples/`` in a temporary
folder, so the gallery starts from nothing (sphinx-gallery skips examples it has already run
next to the sources) and the source tree is left as it was.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
GALLERY = ("plot_scope_capture", "plot_rig_rpm", "plot_levels", "plot_design_robustness", "plot_batch")


@pytest.mark.slow
def test_the_documentation_builds_without_warnings_and_runs_the_gallery(tmp_path):
    pytest.importorskip("sphinx_gallery")
    pytest.importorskip("myst_parser")
    shutil.copytree(REPO / "docs", tmp_path / "docs", ignore=shutil.ignore_patterns("_build", "gallery"))
    shutil.copytree(REPO / "examples", tmp_path / "examples")
    html = tmp_path / "html"
    build = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html",
                            str(tmp_path / "docs"), str(html)],
                           capture_output=True, text=True, cwd=tmp_path, timeout=900)
    assert build.returncode == 0, (build.stdout[-3000:], build.stderr[-3000:])
    assert f"executed {len(GALLERY)} out of {len(GALLERY)} files" in build.stdout

    for name in GALLERY:  # each example ran: its page shows the printed output
        page = (html / "gallery" / f"{name}.html").read_text(encoding="utf-8")
        assert "sphx-glr-script-out" in page, name
    assert "Traceback" not in (html / "gallery" / "plot_scope_capture.html").read_text(encoding="utf-8")

    cli = (html / "cli.html").read_text(encoding="utf-8")
    assert "motorid identify" in cli and "--velocity" in cli and "motorid model from-params" in cli

    api = (html / "python-api.html").read_text(encoding="utf-8")
    assert "motorid.identify" in api and "sample_interval" in api and "Parameters" in api

    tutorial = (html / "tutorial.html").read_text(encoding="utf-8")
    assert "ran when this documentation was built" in tutorial  # docs/_tutorial.py ran its blocks

    for page in ("getting-started", "tutorial", "formats", "laguerre", "batch"):
        assert (html / f"{page}.html").is_file(), page
